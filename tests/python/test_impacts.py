"""Chung & Ooi's (2011) benchmark impacts under each native contact law
(compare/impacts.py, docs/impacts.md) against their analytic limits, and the
same cases in LAMMPS (the linear law) and YADE (the viscoelastic law) against
the native engine. All scenes use integrator.dt = 1e-4; the whole module runs
`compare impacts` once (45 native runs, 15 in LAMMPS, 15 in one YADE process:
about 10 s) and each driver's command line once."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from compare import impacts as im
from compare.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")

# e_n at dt = 1e-4. The contact starts and ends at the first step past the
# range, and the damping force switches on there at full strength (it is
# gamma_n v at first touch), so the error is O(dt), of order g_n dt with g_n
# the damping rate per unit effective mass (8.8 for the linear law's pair,
# the largest here: 9e-4). Measured at dt = 5e-5, 1e-4, 2e-4: at most
# 5e-4 at 1e-4 (linear, head-on), 1.6e-3 at 2e-4.
TOL_E = 1.5e-3
# The gross-sliding changes: the friction at the contact's ends is capped by
# the small |f_n| there, so the step-quantised ends cost less; measured at
# most 2e-5 at dt = 1e-4 and 2e-4 at 2e-4.
TOL_SLIDE = 2e-4
# Two engines running the same law: the same coefficients (granular init's
# derived["linear_law"] / ["viscel_law"]), the same diameters, masses and
# moments of inertia, the same step and the same integrator (LAMMPS's velocity
# Verlet is the native leapfrog's two stages; YADE's leapfrog gives the same
# positions and half-step velocities from a state at rest under no force), so
# the post-impact states differ by rounding only: measured 4e-16 (LAMMPS) and
# 1.2e-14 (YADE) relative at most.
TOL_ENGINES = 1e-6


@pytest.fixture(scope="module")
def res(tmp_path_factory):
    out = tmp_path_factory.mktemp("impacts")
    r = subprocess.run([sys.executable, "-m", "compare", "impacts", "-o", str(out)], cwd=ROOT,
                       capture_output=True, text=True, timeout=300,
                       env={**os.environ, "GRANULAR_BIN": str(BIN)})
    assert r.returncode == 0, r.stderr
    return {"out": out, "stdout": r.stdout, "json": json.loads((out / "impacts.json").read_text())}


def test_subcommand_writes_outputs(res):
    assert (res["out"] / "impacts.json").stat().st_size > 0
    assert (res["out"] / "impacts.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert res["stdout"].startswith("| law | case |")
    assert set(res["json"]["laws"]) == set(im.LAWS)
    for r in res["json"]["laws"].values():
        assert len(r["oblique"]) == len(im.RATIOS)


def test_head_on_momentum(res):
    # The pair force is added to one sphere and subtracted from the other:
    # momentum is conserved to rounding at any step (measured 3e-15).
    for law, r in res["json"]["laws"].items():
        h = r["head_on"]
        assert h["momentum_rel_error"] < 1e-13, law
        assert h["lateral"] == 0.0 and h["spin"] == 0.0, law  # head-on: no tangential motion


def test_restitution_against_analytic(res):
    # Rapaport: the ODE (solve_ivp, rtol 1e-12); linear: exp(-beta pi/omega);
    # viscoelastic: the clipped dashpot's closed form. TOL_E: see above.
    for law, r in res["json"]["laws"].items():
        for case in ("head_on", "wall_normal"):
            q = r[case]
            assert abs(q["e_n"] / q["e_n_analytic"] - 1.0) < TOL_E, (law, case, q)
        # e_n does not depend on the tangential motion (the normal force ignores it), bit for bit
        for q in r["oblique"] + [r["sliding"]]:
            assert q["e_n"] == r["wall_normal"]["e_n"], law


def test_analytic_forms_agree_with_the_ode():
    # The closed forms against the ODE solver they replace (both at ~1e-12).
    for kn, gn in ((57.15, 4.085), (114.3, 8.83), (315.4, 12.95)):
        lin = im.linear_normal(kn, gn, 1.0, 1.0)
        assert abs(lin["e"] / im.linear_restitution(kn, gn)[0] - 1) < 1e-9
        vis = im.linear_normal(kn, gn, 1.0, 1.0, clipped=True)
        assert abs(vis["e"] / im.viscel_restitution(kn, gn)[0] - 1) < 1e-9


def test_linear_map_is_the_engines():
    # The Python map (compare.impacts.linear_map) against the engine's
    # (derived.linear_law of drum #A, with gravity: a static load): the
    # restitution from Rapaport's ODE agrees with the engine's RK4 to ~1e-9.
    r = subprocess.run([str(BIN), "info", "scenes/drum/A.toml", "--json"], cwd=ROOT, capture_output=True,
                       text=True, timeout=60)
    j = json.loads(r.stdout)
    lin = j["derived"]["linear_law"]
    d_small = lin["wall"]["small"]["m_eff"] ** (1 / 3)
    for got, dij, meff, gs in ((lin["pair"]["small_small"], d_small, lin["pair"]["small_small"]["m_eff"], 2.0),
                               (lin["wall"]["small"], 0.5 * (d_small + 1.0), lin["wall"]["small"]["m_eff"], 2.0)):
        want = im.linear_map(dij, meff, 5.0, gs, got["mu"], 1.0, lin["static_load"])
        for k in ("kn", "gamma_n", "xgamma_t"):
            assert abs(want[k] / got[k] - 1) < 1e-8, (k, want[k], got[k])
        assert abs(want["rapaport_restitution"] / got["rapaport"]["restitution"] - 1) < 1e-8


def test_gross_sliding_limit(res):
    # The cap binds throughout (the incidence is above the threshold): the
    # centre's tangential change is -mu J/m and the spin change
    # mu J / (2 kappa m), J = integral |f_n| dt from the law's normal ODE.
    for law in ("rapaport", "linear"):
        r = res["json"]["laws"][law]
        s, lim = r["sliding"], r["sliding"]["limit"]
        assert s["ratio"] > 1.5 * s["cap_threshold_ratio"], law
        assert abs(s["dvt_over_vn"] / lim["dvt"] - 1) < TOL_SLIDE, (law, s, lim)
        assert abs(s["spin"] / lim["dspin"] - 1) < TOL_SLIDE, (law, s, lim)
        assert abs((s["vs_over_vn"] - s["ratio"]) / lim["dvs"] - 1) < TOL_SLIDE, (law, s, lim)
        # Both laws pull at the end of a contact and cap by |f_n|: J exceeds
        # m (1 + e_n) v_n, so the change exceeds Chung & Ooi's mu (1 + e_n) v_n.
        assert lim["J_over_mv"] > 1.05 * lim["one_plus_e"], law
        assert abs(s["dvt_over_vn"]) > 1.05 * abs(lim["dvt_textbook"]), law


def test_cap_transition(res):
    # Below the threshold the friction is viscous for part of the contact and
    # the spin (and |Delta v_t|) is smaller than the capped limit; above it the
    # limit holds (TOL_SLIDE).
    for law in ("rapaport", "linear"):
        r = res["json"]["laws"][law]
        thr, lim = r["cap_threshold_ratio"], r["gross_sliding"]
        below = [q for q in r["oblique"] if q["ratio"] < thr]
        above = [q for q in r["oblique"] if q["ratio"] > thr]
        assert below and above, law
        for q in below:
            assert q["spin"] < lim["dspin"] * (1 - 1e-3), (law, q)
        for q in above:
            assert abs(q["spin"] / lim["dspin"] - 1) < TOL_SLIDE, (law, q)
            assert abs(q["dvt_over_vn"] / lim["dvt"] - 1) < TOL_SLIDE, (law, q)


def test_viscel_tangential_is_linear(res):
    # The viscoelastic law's tangential force is viscous and never capped, so
    # the tangential equations are linear in (v_t, omega), the leapfrog updates
    # too: e_t is the same at every incidence to rounding, and the spin grows
    # in proportion to v_t.
    r = res["json"]["laws"]["viscel"]
    et = np.array([q["e_t"] for q in r["oblique"]])
    assert np.ptp(et) < 1e-9 * abs(et[0])
    spin = np.array([q["spin"] / q["ratio"] for q in r["oblique"]])
    assert np.ptp(spin) < 1e-9 * spin[0]


def _peer(res, law):
    e = res["json"]["engines"][law]
    if "skipped" in e:
        pytest.skip(f"{e['engine']}: {e['skipped']}")
    return e


@pytest.mark.parametrize("law", sorted(im.PEERS))
def test_engines_agree(res, law):
    # Every case of the law in the other engine: every post-impact velocity and
    # surface-spin component within TOL_ENGINES of the native one (relative),
    # the components that are zero (by symmetry) zero there too.
    e = _peer(res, law)
    assert e["engine"] == im.PEERS[law]
    assert len(e["cases"]) == len(im.RATIOS) + 3
    for c in e["cases"]:
        assert c["steps"][0] == c["steps"][1], (law, c)
        assert c["max_rel"] < TOL_ENGINES, (law, c)
        assert c["max_zero"] < 1e-12, (law, c)
        assert abs(c["e_n"][0] / c["e_n"][1] - 1) < TOL_ENGINES, (law, c)
    assert e["max_rel"] < TOL_ENGINES
    assert f"| {law} | {e['engine']} | **all 15 cases**" in res["stdout"]


def test_rapaport_has_no_peer(res):
    assert "rapaport" not in res["json"]["engines"]


def test_particles_scene_reports_the_mapped_laws():
    # granular info on a particles scene gives the coefficients its mapped laws
    # run (derived.linear_law, derived.viscel_law), which LAMMPS and YADE are
    # given; the linear ones as compare.impacts.linear_map computes them
    # (no gravity: Rapaport's stiffness at first touch).
    r = subprocess.run([str(BIN), "info", "scenes/impacts/head_on.toml", "--json"], cwd=ROOT, capture_output=True,
                       text=True, timeout=60)
    d = json.loads(r.stdout)["derived"]
    lin = d["linear_law"]
    assert lin["wall_inset"] == pytest.approx(0.5 * im.CUT, rel=1e-15)
    for got, meff, gs, mu in ((lin["pair"]["small_small"], 0.5, 2.0, 0.1), (lin["wall"]["small"], 1.0, 2.0, 0.1)):
        want = im.linear_map(1.0, meff, 5.0, gs, mu)
        for k in ("kn", "gamma_n", "xgamma_t", "mu"):
            assert abs(want[k] / got[k] - 1) < 1e-8, (k, want[k], got[k])
    ve = d["viscel_law"]["materials"]["small"]
    assert ve["kn"] == 2 * lin["pair"]["small_small"]["kn"]


def _run_cli(module, tmp_path, scene, sets=()):
    out = tmp_path / f"{module}.h5"
    cmd = [sys.executable, "-m", module, "run", scene, "-o", str(out), "-q"]
    for kv in sets:
        cmd += ["--set", kv]
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120,
                       env={**os.environ, "GRANULAR_BIN": str(BIN)})
    assert r.returncode == 0, r.stderr
    return read_run(out)


@pytest.mark.parametrize("module,law,engine", [("lammps_cases", "linear", "lammps"), ("yade_cases", "viscel", "yade")])
def test_driver_runs_a_particles_scene(res, tmp_path, module, law, engine):
    # `python3 -m lammps_cases|yade_cases run SCENE -o OUT --set ...` on a
    # particles scene writes the common schema at the native frames, and the
    # --set override reaches the run: the oblique scene at v_t/v_n = 2 ends as
    # compare impacts' run of that incidence did.
    _peer(res, law)
    p0 = {"x": 0.0, "y": 0.0, "z": 1.2, "vz": -1.0, "d": 1.0, "species": 0}
    run = _run_cli(module, tmp_path, "scenes/impacts/wall_oblique.toml", [im._sphere_list(p0, 2.0)])
    assert run.attrs["engine"] == engine and run.attrs["scene_kind"] == "particles"
    k = list(im.RATIOS).index(2.0)
    ref = read_run(res["out"] / "runs" / f"wall_oblique_{law}_{k}_{engine}.h5")
    assert np.array_equal(run.frames.step, ref.frames.step)
    assert np.array_equal(run.frames.velocity, ref.frames.velocity)
    assert np.array_equal(run.frames.angular_velocity, ref.frames.angular_velocity)
