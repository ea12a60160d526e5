"""The step check of docs/table1.md (compare/table1_step.py) on synthetic
#A runs with known band histories: runs cut at rotation 1000, the band count
there, the first merge, and verdicts that come out equivalent when the two
steps' histories agree and not equivalent when one step merges and the other
does not."""
import json
import math

import h5py
import numpy as np

from compare.table1_step import run_until, step_check, step_lines
from compare.reader import read_run
from synthetic import banded_y, random_bed, species_and_diameters, write_drum_run

N = 2000
EVERY = 50  # rotations between snapshots


def _run(path, rng, sp, d, bands_of, rotations, dt):
    """A run whose snapshot at rotation r has bands_of(r) bands."""
    rots = np.arange(0, rotations + 1, EVERY)
    beds = [random_bed(rng, N, y=banded_y(rng, sp, bands_of(r)) if bands_of(r) else None) for r in rots]
    period = 2 * math.pi / 0.5
    write_drum_run(path, np.array(beds), sp, d, times=rots * period)
    with h5py.File(path, "r+") as f:
        scene = json.loads(f.attrs["scene_json"])
        scene["integrator"] = {"dt": dt}
        f.attrs["scene_json"] = json.dumps(scene)
    path.with_name(path.name + ".done").touch()
    return path


def _setup(tmp_path, merge_at_large):
    """#A (0.01, seed 1, 1200 rotations) and seeds 2-4 at 0.005 and 2-3 at 0.01;
    every run forms 8 bands at rotation 50; the 0.01 runs merge at
    merge_at_large (None: never) to 4, two band pairs fewer."""
    rng = np.random.default_rng(3)
    sp, d = species_and_diameters(rng, N)
    runs = tmp_path / "runs"
    (runs / "step").mkdir(parents=True)
    steady = lambda r: 8 if r >= 50 else 0
    merging = (lambda r: 0 if r < 50 else (8 if merge_at_large is None or r < merge_at_large else 4))
    _run(runs / "A.h5", rng, sp, d, merging, 1200, 0.01)
    for s in (2, 3, 4):
        _run(runs / "step" / f"A_dt0.005_s{s}.h5", rng, sp, d, steady, 1000, 0.005)
    for s in (2, 3):
        _run(runs / "step" / f"A_dt0.01_s{s}.h5", rng, sp, d, merging, 1000, 0.01)
    return runs


def test_run_until_cuts_at_the_rotation(tmp_path):
    runs = _setup(tmp_path, None)
    run = read_run(runs / "A.h5")
    cut = run_until(run, 1000)
    t = cut.frames.time / run.rotation_period
    assert abs(t[-1] - 1000) < 1e-9 and cut.frames.n_frames == 21 and run.frames.n_frames == 25
    assert cut.frames.position.shape[0] == 21


def test_same_histories_are_equivalent(tmp_path):
    check = step_check(_setup(tmp_path, None))
    assert check["steps"] == [0.005, 0.01]
    runs = check["runs"]
    assert len(runs) == 6 and all(r["complete"] for r in runs)
    assert {r["bands_1000"] for r in runs} == {8}
    assert all(r["first_merge"] is None for r in runs)
    a = next(r for r in runs if r["file"].endswith("A.h5"))
    assert a["dt"] == 0.01 and a["seed"] == 1 and abs(a["rotations_reached"] - 1000) < 1e-9
    assert check["verdicts"]["bands_1000"]["verdict"] == "equivalent"


def test_a_merge_at_one_step_only_is_not_equivalent(tmp_path):
    check = step_check(_setup(tmp_path, 300))
    large = [r for r in check["runs"] if r["dt"] == 0.01]
    assert {r["bands_1000"] for r in large} == {4}
    assert all(250 <= r["first_merge"] <= 325 for r in large), [r["first_merge"] for r in large]
    assert check["verdicts"]["bands_1000"]["verdict"] == "different"
    fm = check["verdicts"]["first_merge"]
    assert fm["a"] == [1001.0] * 3 and len(fm["b"]) == 3 and fm["p"] < 0.2
    text = "\n".join(step_lines(check))
    assert "| 0.01 | 1 | 1000 |" in text and "| bands at rotation 1000 | 3 + 3 | -4.00 |" in text
    assert "different" in text
    # each row reports how far its pattern wandered, or "–" where no mode could be followed
    rows = [l for l in text.splitlines() if l.startswith("| 0.0")]
    assert len(rows) == 6 and all(l.count("|") == 10 for l in rows)
    for r in check["runs"]:
        p = r["pattern"]
        assert p is None or (p["rotations"] >= 200 and 128 / p["wavelength"] == round(128 / p["wavelength"]))
