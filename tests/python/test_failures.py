"""Runs driven into each failure on purpose (engine/health.hpp,
engine/simulation.hpp, the scenes' containment checks): each stops with exit
status 3 and one message naming the step or time, the particle(s), what went
wrong and the likely cause, and leaves an output that opens, holds what was
written before, and has no NaN in it."""
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from compare.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
DRUM = ROOT / "scenes" / "drum" / "A.toml"
BOX = ROOT / "scenes" / "box" / "f3.0_big.toml"
SMALL_BOX = ["particles.count=300", "box.width=30"]
UNDAMPED = ["contact.gamma_n=0", "friction.gamma_s_bb=0", "friction.gamma_s_ss=0", "friction.gamma_s_bw=0",
            "friction.gamma_s_sw=0"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")

CASES = {
    # Rapaport's contact lasts ~0.21 time units: a step of 0.2 cannot resolve it.
    "step_longer_than_the_contact": (
        DRUM, ["drum.length=32", "integrator.dt=0.2", "run.rotations=2", "run.snapshot_every=0.01"],
        ["more than half the smallest diameter", "Likely cause: integrator.dt = 0.2 is 1/1.1 of the shortest "
                                                "contact period"]),
    # No damping, no gravity, a wall barely turning, a step of 1/6 of the contact
    # and a skin wide enough that the list does not stop it first: the gas heats
    # up by itself until it moves 8x faster than anything drives it.
    "energy_without_a_source": (
        DRUM, ["drum.length=32", "integrator.dt=0.03", "neighbor.skin=3", "gravity.g=0", "drum.omega=0.01",
               "run.rotations=0.5", "run.snapshot_every=0.02"] + UNDAMPED,
        ["energy is growing without a source", "Likely cause: integrator.dt = 0.03 is 1/5.8"]),
    # Y 3000x softer than the paper's: the pile sinks into itself under its weight.
    "contacts_too_soft": (
        BOX, SMALL_BOX + ["contact.young=1000", "run.settle=1", "run.duration=1"],
        ["overlap by", "% of their contact distance", "too soft for the load"]),
    # 12 Hz (Gamma = 11.6) with low walls: grains fly out over the side walls.
    "grain_over_the_wall": (
        BOX, SMALL_BOX + ["shaking.frequency=12", "box.wall_height=25", "run.settle=0.3", "run.duration=3"],
        ["escaped the box", "flew over a side wall", "raise box.wall_height"]),
    # The same over smooth walls (box.walls = "smooth"), which end at the same height.
    "grain_over_the_smooth_wall": (
        BOX, SMALL_BOX + ["box.walls=smooth", "shaking.frequency=12", "box.wall_height=25", "run.settle=0.3",
                          "run.duration=3"],
        ["escaped the box", "flew over a side wall", "raise box.wall_height"]),
    # Smooth walls are not in the neighbour list: their overlaps have a check of
    # their own. One layer of grains and the big disk (m = 100 g) on a floor
    # 3000x softer than the paper's sink into the floor, not into each other.
    "floor_too_soft": (
        BOX, SMALL_BOX + ["box.walls=smooth", "particles.count=10", "contact.young=1000", "run.settle=1",
                          "run.duration=0.5"],
        ["overlaps the floor by", "% of its contact distance with the wall", "too soft for the load"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_failure_is_detected_named_and_leaves_a_clean_file(case, tmp_path):
    scene, sets, fragments = CASES[case]
    out = tmp_path / f"{case}.h5"
    cmd = [str(BIN), "run", str(scene), "-o", str(out), "-q", "--threads", "1"]
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 3, r.stderr
    err = [ln for ln in r.stderr.splitlines() if ln.startswith("error:")]
    assert len(err) == 1, r.stderr
    for f in fragments:
        assert f in err[0], f"{f!r} not in {err[0]!r}"
    assert "particle" in err[0] or "grain id" in err[0]
    assert "step" in err[0] or "t = " in err[0]
    run = read_run(out)
    assert run.frames.n_frames >= 1
    for name in ("position", "velocity", "angular_velocity"):
        assert np.all(np.isfinite(getattr(run.frames, name))), name
