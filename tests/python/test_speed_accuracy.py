"""The binary-collision sweep (native/tools/collision_sweep.cpp,
compare/speed_accuracy.py): every method converges to its reference at the
order its integrator should have, and the Pareto front is what it says."""
import math
import os
from pathlib import Path

import numpy as np
import pytest

from compare.speed_accuracy import RATES, cheapest_within, pareto, run_sweep

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_COLLISION_SWEEP", ROOT / "build" / "collision_sweep"))

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


@pytest.fixture(scope="module")
def rows():
    return run_sweep(BIN)


def slope(rows, method, key, damped, lo, hi):
    rs = [r for r in rows if r["method"] == method and r["damped"] == damped and lo <= r["steps_per_contact"] <= hi
          and not r["scene_dt"]]
    x = np.log([r["steps_per_contact"] for r in rs])
    y = np.log([r[key] for r in rs])
    return np.polyfit(x, y, 1)[0]


@pytest.mark.parametrize("method", sorted(RATES))
def test_undamped_energy_error_is_second_order(rows, method):
    # The contact switches on and off inside a step, so no method beats second
    # order on a collision, Gear included; all reach it.
    s = slope(rows, method, "energy_error", False, 64, 1000)
    assert -2.4 < s < -1.7, f"{method}: energy error ~ n^{s:.2f}"


@pytest.mark.parametrize("method", sorted(RATES))
def test_damped_collision_converges_to_its_reference(rows, method):
    fine = [r for r in rows if r["method"] == method and r["damped"] and r["steps_per_contact"] == 1000][0]
    coarse = [r for r in rows if r["method"] == method and r["damped"] and r["steps_per_contact"] == 16][0]
    assert fine["restitution_error"] < 1e-4
    assert fine["contact_time_rel_error"] < 1e-3
    assert fine["contact_time_rel_error"] < coarse["contact_time_rel_error"] or fine["contact_time_rel_error"] < 1e-6


def test_analytic_references_are_the_linear_spring_dashpot(rows):
    r = [r for r in rows if r["method"] == "box poeschel-herrmann leapfrog" and r["damped"]][0]
    assert r["reference"] == "analytic"
    assert 0.85 < r["reference_restitution"] < 0.9  # Y = 3e6, gamma_N = 100, R = 0.85 (paper's constants)
    undamped = [r for r in rows if not r["damped"] and r["reference"] == "analytic"]
    assert all(r["reference_restitution"] == pytest.approx(1.0, abs=1e-9) for r in undamped)


def test_pareto_front():
    pts = [(1, 5), (2, 3), (3, 4), (4, 1), (5, 1), (0.5, 10)]
    assert sorted(pareto(pts)) == [0, 1, 3, 5]


def test_cheapest_within_needs_every_smaller_step_within(rows):
    m = "drum rapaport leapfrog"
    r = cheapest_within(rows, m, "contact_time_rel_error", 0.01)
    assert r is not None and r["contact_time_rel_error"] <= 0.01
    finer = [x for x in rows if x["method"] == m and x["damped"] and x["dt"] < r["dt"]]
    assert all(x["contact_time_rel_error"] <= 0.01 for x in finer)
    assert not math.isnan(r["dt"])
