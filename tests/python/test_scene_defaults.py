"""Every shipped scene runs at its defaults through its most violent phase.

The drum's fill starts as an fcc lattice over the whole cross-section and
collapses under gravity onto grains the wall carries up: the fastest impacts
of the run (free fall across the drum plus the wall's speed), after which the
flow is slower. The box's grains settle from their lattice and are then
shaken; the first second of shaking holds the first hard impacts of the floor.
Each scene runs here at its own step (scene/step_rule.hpp; nothing but the run
length and the output cadence is overridden) over the drum's collapse and
first half rotation, or the box's settling and first second of shaking, and
must finish without the engine stopping it, with finite state and every
particle in its container. A default step too long for a scene's impacts
stops the run in this phase (#T at 0.01 did, in 3 seeds of 4).
"""
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from compare.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
DRUMS = sorted((ROOT / "scenes" / "drum").glob("*.toml"))
BOXES = sorted((ROOT / "scenes" / "box").glob("*.toml"))

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def granular(*args):
    return subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True, timeout=600)


def info(scene):
    r = granular("info", scene, "--json")
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def test_every_scene_is_shipped():
    assert len(DRUMS) == 24 and len(BOXES) >= 13


@pytest.mark.parametrize("scene", DRUMS + BOXES, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_default_step_comes_from_the_rule(scene):
    """info --json reports the step the scene resolves to; with no
    integrator.dt in the scene it is the rule's, which keeps the required
    steps per shortest contact and never exceeds the accuracy step."""
    j = info(scene)
    step = j["derived"]["time_step"]
    assert step["dt"] == step["default"] == j["integrator"]["dt"]
    assert step["dt"] <= step["accuracy_step"]
    assert step["steps_per_contact"] >= step["steps_per_contact_required"]
    # two significant digits, rounded down: within 10 % of the bound it rounds
    bound = min(step["accuracy_step"], step["contact_time"] / step["steps_per_contact_required"])
    assert 0.9 * bound <= step["dt"] <= bound


def test_rule_shortens_the_step_for_a_wider_drum():
    """The contact at the fastest impact shortens as the drum widens (a longer
    fall): #T (D = 32) resolves to a shorter step than #J (D = 24), which is
    shorter than #A's (D = 16, at the accuracy step 0.01)."""
    dt = {s: info(ROOT / "scenes" / "drum" / f"{s}.toml")["derived"]["time_step"]["dt"] for s in "AJT"}
    assert dt["A"] == 0.01 and dt["T"] < dt["J"] < dt["A"]


def check_run(out, container):
    run = read_run(out)
    x = run.frames.position
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(run.frames.velocity))
    container(run, x[-1])


def inside_drum(run, x):
    d = run.scene["drum"]
    r = np.hypot(x[:, 0], x[:, 2])
    assert r.max() < 0.5 * d["diameter"]
    if d["ends"] == "capped":
        assert np.abs(x[:, 1]).max() < 0.5 * d["length"]


def inside_box(run, x):
    species = run.frames.species[-1]
    grains = x[species != 2]
    half = 0.5 * run.scene["box"]["width"]
    assert np.abs(grains[:, 0]).max() < half  # W: between the side walls' surfaces


@pytest.mark.parametrize("scene", DRUMS, ids=lambda p: p.stem)
def test_drum_survives_collapse_and_half_rotation(scene, tmp_path):
    out = tmp_path / "run.h5"
    r = granular("run", scene, "-o", out, "--threads", "2", "-q", "--set", "run.rotations=0.5",
                 "--set", "run.snapshot_every=0.25", "--set", "run.profile_every=0.25")
    assert r.returncode == 0, f"{scene.name} at its defaults: {r.stderr}"
    check_run(out, inside_drum)


@pytest.mark.parametrize("scene", BOXES, ids=lambda p: p.stem)
def test_box_survives_settling_and_first_second(scene, tmp_path):
    out = tmp_path / "run.h5"
    r = granular("run", scene, "-o", out, "--threads", "2", "-q", "--set", "run.duration=1",
                 "--set", "run.snapshot_every_cycles=1")
    assert r.returncode == 0, f"{scene.name} at its defaults: {r.stderr}"
    check_run(out, inside_box)
