"""compare.step_sweep: how a run's outcome is classified, how the error
against the converged reference and the tolerance verdict are computed, and
the Pareto front. Synthetic inputs; the sweep's runs themselves are the
engines' (docs/stability.md)."""
import math

import numpy as np

from compare.step_sweep import Run, classify, pareto, stability_limits, summarise


def native_failure(text):
    return {"returncode": 3, "stderr_tail": "granular 0.1.0: drum A ...\n\nerror: " + text +
            "\n(the output file keeps every frame written before this point)\n", "path": "/nonexistent.h5"}


RUN = Run("drum native rapaport", 0.02, 1, ["run.rotations=1"], "stability")


def test_classify_names_each_native_failure_and_quotes_the_error_line():
    cases = {
        "simulation unstable at step 76 (t = 1.52): particle id 890 moved 0.285 in one step, more than the "
        "neighbour list allows (0.2 = skin/2); speed 14.2": "too fast for the step",
        "simulation unstable at step 77 (t = 1.54): particle id 890 moved 0.452 in one step, more than half the "
        "smallest diameter (0.4): collisions are not resolved; speed 22.6": "too fast for the step",
        "simulation unstable at step 9: particle id 3 has a non-finite position or velocity": "non-finite",
        "simulation unstable at step 9: particle id 3 moves at 99, faster than anything in the scene drives it "
        "(wall 4, limit 32): energy is growing without a source": "energy rising",
        "simulation unstable at step 200 (t = 2): particles id 529 and 532 overlap by 40.9 % of their contact "
        "distance (limit 40 %)": "deep overlap",
        "simulation unstable at step 1257: particle id 148 left the drum at (0.3, -13.2, -11.3)": "escaped",
    }
    for text, status in cases.items():
        got, msg = classify(RUN, native_failure(text))
        assert got == status, (text, got)
        assert msg.startswith("error: simulation unstable"), msg


def test_classify_reads_a_finished_runs_output_for_silent_failures(tmp_path):
    import h5py
    path = tmp_path / "run.h5"
    x = np.zeros((1, 4, 3))
    x[0, :, 0] = [0.0, 1.0, 2.0, 3.0]
    with h5py.File(path, "w") as h5:
        h5["frames/position"] = x
        h5["frames/species"] = np.zeros((1, 4), dtype=np.int32)
    ok = {"returncode": 0, "stderr_tail": "", "path": str(path)}
    assert classify(RUN, ok)[0] == "ok"
    with h5py.File(path, "r+") as h5:
        h5["frames/position"][0, 2, 2] = 12.0   # radius 12 > D/2 + 1 = 9
    assert classify(RUN, ok)[0] == "silent escape"
    with h5py.File(path, "r+") as h5:
        h5["frames/position"][0, 1, 1] = np.nan
    assert classify(RUN, ok)[0] == "silent non-finite"


def row(dt, seed, slope, status="ok", cpu=1.0):
    return {"method": "drum native rapaport", "kind": "drum", "dt": dt, "seed": seed, "status": status,
            "slope_deg": slope, "cpu_per_unit": cpu / dt, "detail": ""}


def test_summary_errors_against_the_smallest_step_and_the_tolerance():
    rows = [row(0.001, s, 20.0 + d) for s, d in ((1, -0.5), (2, 0.0), (3, 0.5))]
    rows += [row(0.002, s, 21.0 + d) for s, d in ((1, -0.5), (2, 0.0), (3, 0.5))]      # 1 degree off
    rows += [row(0.004, s, 24.5 + d) for s, d in ((1, -0.5), (2, 0.0), (3, 0.5))]      # 4.5 degrees off
    rows += [row(0.008, 1, 20.0), row(0.008, 2, None, status="too fast for the step")]  # a seed failed
    s = summarise(rows)["drum native rapaport"]
    by = {e["dt"]: e for e in s["steps"]}
    assert s["reference_dt"] == 0.001 and by[0.001]["slope_deg_error"] == 0.0
    assert math.isclose(by[0.002]["slope_deg_error"], 1.0) and by[0.002]["within_tolerance"]
    assert math.isclose(by[0.004]["slope_deg_error"], 4.5) and not by[0.004]["within_tolerance"]
    assert not by[0.008]["within_tolerance"], "a step where a seed failed is never within tolerance"
    # standard error of the difference of two means of three values with sd 0.5
    assert math.isclose(by[0.002]["slope_deg_error_se"], math.hypot(0.5 / math.sqrt(3), 0.5 / math.sqrt(3)))
    assert s["cheapest_within_tolerance"] == 0.002


def test_stability_limits_take_the_first_failure_above_the_last_success():
    rows = [dict(row(dt, 1, 20.0, status=st), param="drum.omega", value=1.0)
            for dt, st in ((0.005, "ok"), (0.01, "ok"), (0.02, "too fast for the step"), (0.04, "non-finite"))]
    (lim,) = stability_limits(rows)
    assert lim["largest_stable_dt"] == 0.01 and lim["first_failure_dt"] == 0.02
    assert lim["failure"] == "too fast for the step"


def test_pareto_front():
    pts = [(1.0, 5.0), (2.0, 1.0), (3.0, 2.0), (0.5, 9.0), (4.0, 0.5)]
    assert sorted(pareto(pts)) == [0, 1, 3, 4]
