"""The particles scene (docs/particles_scene.md) end to end: `granular run` on
spheres from a CSV file and on one frame of a drum run's output, read back
through compare.reader.read_run; `granular init` and `info --json`; --resume
refused."""
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from compare.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")

FRICTION = """
[friction]
gamma_s_bb = 10.0
gamma_s_ss = 2.0
gamma_s_bw = 10.0
gamma_s_sw = 2.0
"""


def granular(*args, cwd=ROOT):
    return subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True, timeout=600, cwd=cwd)


def csv_scene(tmp_path):
    (tmp_path / "spheres.csv").write_text(
        "x, y, z, vx, vy, vz, wy, d, species\n"
        "0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 1.0, 0\n"
        "1.5, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.3, 1\n"
        "0.0, 1.5, 2.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0\n")
    scene = tmp_path / "csv.toml"
    scene.write_text('[scene]\nkind = "particles"\nname = "csv"\n[particles]\ncsv = "spheres.csv"\n'
                     "[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
                     "[gravity]\ng = 5.0\n[run]\nduration = 0.5\nsnapshot_every = 0.1\n" + FRICTION)
    return scene


def test_csv_scene_runs_and_reads_back(tmp_path):
    scene = csv_scene(tmp_path)
    out = tmp_path / "csv.h5"
    r = granular("run", scene, "-o", out)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "csv.xdmf").exists()
    run = read_run(out)
    assert run.attrs["scene_kind"] == "particles"
    assert run.dim == 3
    f = run.frames
    assert f.n_particles == 3
    np.testing.assert_allclose(f.time, np.arange(6) * 0.1, atol=1e-9)
    np.testing.assert_array_equal(f.species[0], [0, 1, 0])
    np.testing.assert_array_equal(f.diameter[0], [1.0, 1.3, 1.0])
    np.testing.assert_array_equal(f.position[0], [[0, 0, 1], [1.5, 0, 1], [0, 1.5, 2]])
    np.testing.assert_array_equal(f.velocity[0, :, 0], [0.5, 0.0, 0.0])
    np.testing.assert_array_equal(f.angular_velocity[0, 1], [0.0, 1.0, 0.0])
    assert f.species_names == ("small", "big")
    assert np.all(f.position[:, :, 2] > 0.0)  # above the wall throughout
    assert run.profile is None


def test_info_init_and_resume(tmp_path):
    scene = csv_scene(tmp_path)
    r = granular("info", scene, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)["derived"]
    assert d["particles"] == 3 and d["particles_small"] == 2 and d["particles_big"] == 1 and d["walls"] == 1
    assert d["time_step"]["dt"] == d["time_step"]["default"] <= 0.01
    assert d["time_step"]["steps_per_contact"] >= 4.0
    init = tmp_path / "init.h5"
    r = granular("init", scene, "-o", init)
    assert r.returncode == 0, r.stderr
    run = read_run(init)
    assert run.frames.n_frames == 1 and run.frames.n_particles == 3
    r = granular("run", scene, "-o", tmp_path / "never.h5", "--resume")
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "--resume is not available" in r.stderr
    assert not (tmp_path / "never.h5").exists()


def test_a_drum_frame_starts_a_particles_run(tmp_path):
    drum = tmp_path / "drum.h5"
    r = granular("run", "scenes/drum/A.toml", "-o", drum, "--set", "run.rotations=0.05",
                 "--set", "run.snapshot_every=0.05", "--set", "drum.length=32")
    assert r.returncode == 0, r.stderr
    source = read_run(drum).frames
    scene = tmp_path / "from_drum.toml"
    scene.write_text('[scene]\nkind = "particles"\nname = "from_drum"\n[particles]\nh5 = "drum.h5"\nframe = -1\n'
                     "[gravity]\ng = 5.0\n[run]\nduration = 0.1\nsnapshot_every = 0.05\n" + FRICTION)
    out = tmp_path / "from_drum.h5"
    r = granular("run", scene, "-o", out)
    assert r.returncode == 0, r.stderr
    run = read_run(out)
    assert run.attrs["scene_kind"] == "particles"
    f = run.frames
    assert f.n_particles == source.n_particles > 100
    np.testing.assert_array_equal(f.position[0], source.position[-1])
    np.testing.assert_array_equal(f.velocity[0], source.velocity[-1])
    np.testing.assert_array_equal(f.angular_velocity[0], source.angular_velocity[-1])
    np.testing.assert_array_equal(f.diameter[0], source.diameter[-1])
    np.testing.assert_array_equal(f.species[0], source.species[-1])
    np.testing.assert_allclose(f.time, [0.0, 0.05, 0.1], atol=0.01)  # frames at the nearest steps
    # A frame the file does not hold is refused, naming particles.frame.
    r = granular("run", scene, "-o", tmp_path / "x.h5", "--set", "particles.frame=7")
    assert r.returncode == 2 and "particles.frame (--set): frame 7 is not in drum.h5" in r.stderr
