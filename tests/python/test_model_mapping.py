"""The map from Rapaport's law to the linear law (docs/model_mapping.md):
Rapaport's head-on collision recomputed independently with SciPy, the linear
law's restitution equal to it, and the overlap under the static load equal."""

import json
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[2]
C = 2 ** (1 / 6)


def lj(r, d):
    s6 = (d / r) ** 6
    return 48 / r * s6 * (s6 - 0.5) if r < C * d else 0.0


def collision(d, meff, gn, v):
    ev = lambda t, y: y[0] - C * d
    ev.terminal, ev.direction = True, 1
    sol = solve_ivp(lambda t, y: [y[1], (lj(y[0], d) - gn * y[1]) / meff], [0, 100], [C * d - 1e-12, -v],
                    events=ev, rtol=1e-11, atol=1e-13, max_step=1e-3)
    return sol.y_events[0][0][1] / v, sol.t_events[0][0]


@pytest.fixture(scope="module")
def mapping():
    exe = os.environ.get("GRANULAR_BIN", str(ROOT / "build" / "granular"))
    out = subprocess.run([exe, "info", "scenes/drum/A.toml", "--json"], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out)["derived"]["linear_law"]


@pytest.mark.parametrize("pair,d,meff", [("small_small", 0.9, 0.9 ** 3 / 2), ("big_big", 1.2, 1.2 ** 3 / 2),
                                         ("small_big", 1.05, 0.9 ** 3 * 1.2 ** 3 / (0.9 ** 3 + 1.2 ** 3))])
def test_rapaport_collision_and_linear_match(mapping, pair, d, meff):
    m = mapping["pair"][pair]
    e, tc = collision(d, meff, 5.0, mapping["impact_speed"])
    assert m["m_eff"] == pytest.approx(meff, rel=1e-12)
    assert m["rapaport"]["restitution"] == pytest.approx(e, rel=1e-7)
    assert m["rapaport"]["contact_time"] == pytest.approx(tc, rel=1e-7)
    # the linear law's own collision (analytic) has the same restitution
    beta = m["gamma_n"] / 2
    w = math.sqrt(m["kn"] / meff - beta ** 2)
    assert math.exp(-beta * math.pi / w) == pytest.approx(e, rel=1e-9)
    # same overlap under the static load F*
    F = mapping["static_load"]
    r = brentq(lambda r: lj(r, d) - F, 0.8 * d, C * d)
    assert F / m["kn"] == pytest.approx(C * d - r, rel=1e-9)


def test_walls_move_in_by_half_the_contact_diameter_of_the_wall(mapping):
    assert mapping["wall_inset"] == pytest.approx(C / 2, rel=1e-12)
    assert mapping["contact_diameter"] == pytest.approx(16.0 - C, rel=1e-12)
    # friction: x_t g_n m_eff equals Rapaport's gamma_s (2 for small-small in #A)
    s = mapping["pair"]["small_small"]
    assert s["xgamma_t"] * s["gamma_n"] * s["m_eff"] == pytest.approx(2.0, rel=1e-12)
