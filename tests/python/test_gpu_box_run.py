"""`granular run --device gpu-host` for the shaken box: the CPU engine's run
loop, output, health checks and checkpoints, with the state stepped by the
box's GPU kernels built by the host compiler (docs/gpu.md). It writes the
CPU engine's output schema and follows the CPU engine to rounding, with
walls of particles or smooth walls and either integrator; a resumed run
repeats the uninterrupted one bit for bit; an unstable run stops with the
CPU engine's message; replica k of `--replicas K` is, bit for bit, the
single run with seed + k, and resumes bit for bit; `granular bench` times
the box's stepper, replicas too."""
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from test_gpu_run import BIN, ROOT, assert_bitwise_equal, assert_same_schema, by_id, datasets

BOX = ROOT / "scenes" / "box" / "f3.0_big.toml"
# scenes/box/f3.0_big.toml shrunk to 12 cm by 14 cm with 30 grains and a big
# disk of radius 2 cm, shaken at full amplitude from t = 0.02 s for 0.1 s
# (600 steps of 2e-4 s): the grains land on the floor and each other, the
# floor jolts them. Frames every 1/60 s, the trace 60 rows a second.
SETS = ["box.width=12", "box.wall_height=14", "particles.count=30", "big.radius=2", "big.gap=1",
        "run.settle=0.02", "shaking.startup_cycles=0", "run.duration=0.1", "run.snapshot_every_cycles=0.05"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def run(*args, sets=SETS, threads=1):
    c = [str(BIN), "run", str(args[0]), "-q", "--threads", str(threads), *map(str, args[1:])]
    for s in sets:
        c += ["--set", s]
    return subprocess.run(c, capture_output=True, text=True, timeout=600, cwd=ROOT)


# Walls of particles with Gear's predictor-corrector (the paper's), smooth
# walls with the leapfrog.
MODELS = {"particles_gear": ["box.walls=particles", "integrator.kind=gear"],
          "smooth_leapfrog": ["box.walls=smooth", "integrator.kind=leapfrog"]}


@pytest.fixture(scope="module", params=sorted(MODELS))
def cpu_and_gpu_host(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("box_" + request.param)
    sets = SETS + MODELS[request.param]
    cpu, gpu = tmp / "cpu.h5", tmp / "gpu.h5"
    r = run(BOX, "-o", cpu, sets=sets)
    assert r.returncode == 0, r.stderr
    r = run(BOX, "-o", gpu, "--device", "gpu-host", sets=sets)
    assert r.returncode == 0, r.stderr
    assert "device gpu-host" in r.stderr
    return cpu, gpu


def test_gpu_host_box_writes_the_cpu_schema(cpu_and_gpu_host):
    _, dg = assert_same_schema(*cpu_and_gpu_host)
    assert "trace/big_position" in dg and "frames/position" in dg


def test_gpu_host_box_follows_the_cpu_engine(cpu_and_gpu_host):
    """Frames matched by id: the two engines sum a particle's contacts in
    another order, so they agree to rounding, which the collisions amplify;
    after 600 steps positions agree to 1e-11 cm (measured: 6e-14 cm, 5e-15
    of the box's width), the trace of the big disk and the Coulomb census to
    1e-9."""
    dc, dg = (datasets(p) for p in cpu_and_gpu_host)
    assert np.array_equal(dc["frames/time"], dg["frames/time"])
    assert dc["frames/time"].shape[0] >= 6
    xc, xg = by_id(dc, "frames/position"), by_id(dg, "frames/position")
    assert np.abs(xc[-1] - xc[0]).max() > 0.5  # the grains moved
    dx = np.abs(xg - xc).max()
    print(f"largest position difference {dx:.3g} cm")
    assert dx < 1e-11
    for name in dc:
        if name.startswith(("trace/", "coulomb/")):
            np.testing.assert_allclose(dg[name], dc[name], rtol=1e-9, atol=1e-9, err_msg=name)


def test_gpu_host_box_resumes_bitwise(tmp_path):
    """0.0334 s of shaking (267 steps, the first at or after the second
    frame's time, where the uninterrupted run writes one too) with a
    checkpoint every 100 steps, then --resume to 0.1 s: every dataset is the
    uninterrupted run's, bit for bit (the checkpoint holds the stepper's
    particle order, Gear's scaled derivatives and its neighbour list's
    reference positions)."""
    whole, parts = tmp_path / "whole.h5", tmp_path / "parts.h5"
    sets = SETS + MODELS["particles_gear"]
    assert run(BOX, "-o", whole, "--device", "gpu-host", sets=sets).returncode == 0
    first = [s if not s.startswith("run.duration") else "run.duration=0.0334" for s in sets]
    r = run(BOX, "-o", parts, "--device", "gpu-host", "--checkpoint-steps", 100, sets=first)
    assert r.returncode == 0, r.stderr
    assert Path(str(parts) + ".ckpt").exists()
    r = run(BOX, "-o", parts, "--device", "gpu-host", "--resume", sets=sets)
    assert r.returncode == 0, r.stderr
    assert "resuming from step 267" in r.stderr
    assert_bitwise_equal(whole, parts)


def test_box_checkpoints_resume_on_their_own_engine_only(tmp_path):
    for wrote, other in (("gpu-host", "cpu"), ("cpu", "gpu-host")):
        out = tmp_path / f"{wrote}.h5"
        assert run(BOX, "-o", out, "--device", wrote).returncode == 0
        r = run(BOX, "-o", out, "--device", other, "--resume")
        assert r.returncode == 2, r.stderr
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and "resume it with --device" in lines[0], r.stderr


def test_unstable_box_stops_with_the_cpu_message(tmp_path):
    """integrator.dt 20 times the default: both engines stop at the same step
    with status 3 and the same message (the CPU engine's check names the
    culprit from the state the GPU engine downloads)."""
    bad = SETS + ["integrator.dt=4e-3", "run.snapshot_every_cycles=0.01"]
    errors = {}
    for device in ("cpu", "gpu-host"):
        out = tmp_path / f"{device}.h5"
        r = run(BOX, "-o", out, "--device", device, sets=bad)
        assert r.returncode == 3, r.stderr
        (errors[device],) = [ln for ln in r.stderr.splitlines() if ln.startswith("error: ")]
        for name, v in datasets(out).items():
            if name.startswith("frames/") and v.dtype.kind == "f":
                assert not np.isnan(v).any(), f"{device}: {name} holds NaN"
    assert errors["cpu"].startswith("error: simulation unstable at step "), errors["cpu"]
    assert errors["gpu-host"] == errors["cpu"]


def seed_of(sets):
    """The scene's particles.seed with these --set options (the default: 1)."""
    for x in sets:
        if x.startswith("particles.seed="):
            return int(x.split("=", 1)[1])
    import tomllib
    with open(BOX, "rb") as f:
        return tomllib.load(f).get("particles", {}).get("seed", 1)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_box_replicas_are_the_single_runs_bitwise(tmp_path, model):
    """--replicas 3 writes OUT_r00.h5 .. OUT_r02.h5; replica k's datasets are
    the single run's with particles.seed = seed + k, bit for bit: the
    replicas share the stepper's kernels, each its own list and cells."""
    sets = SETS + MODELS[model]
    seed = seed_of(sets)
    r = run(BOX, "-o", tmp_path / "rep.h5", "--device", "gpu-host", "--replicas", 3, sets=sets)
    assert r.returncode == 0, r.stderr
    assert f"3 replicas (particles.seed {seed} to {seed + 2})" in r.stderr
    assert sorted(p.name for p in tmp_path.glob("rep*.h5")) == ["rep_r00.h5", "rep_r01.h5", "rep_r02.h5"]
    firsts = []
    for k in range(3):
        single = tmp_path / f"single{k}.h5"
        r = run(BOX, "-o", single, "--device", "gpu-host", sets=sets + [f"particles.seed={seed + k}"])
        assert r.returncode == 0, r.stderr
        assert_bitwise_equal(single, tmp_path / f"rep_r{k:02d}.h5")
        firsts.append(datasets(single)["frames/position"][-1])
    assert not np.array_equal(firsts[0], firsts[1])  # other seeds, other packings


def test_box_replicas_resume_bitwise(tmp_path):
    """Replicas stopped at step 267 with their checkpoints, then --resume with
    the same K: each replica's datasets are the uninterrupted replicas', bit
    for bit."""
    sets = SETS + MODELS["smooth_leapfrog"]
    r = run(BOX, "-o", tmp_path / "whole.h5", "--device", "gpu-host", "--replicas", 2, sets=sets)
    assert r.returncode == 0, r.stderr
    first = [s if not s.startswith("run.duration") else "run.duration=0.0334" for s in sets]
    r = run(BOX, "-o", tmp_path / "parts.h5", "--device", "gpu-host", "--replicas", 2, "--checkpoint-steps", 100,
            sets=first)
    assert r.returncode == 0, r.stderr
    for k in range(2):
        assert (tmp_path / f"parts_r{k:02d}.h5.ckpt").exists()
    r = run(BOX, "-o", tmp_path / "parts.h5", "--device", "gpu-host", "--replicas", 2, "--resume", sets=sets)
    assert r.returncode == 0, r.stderr
    assert "resuming from step 267" in r.stderr
    for k in range(2):
        assert_bitwise_equal(tmp_path / f"whole_r{k:02d}.h5", tmp_path / f"parts_r{k:02d}.h5")


def test_box_replicas_on_the_cpu_are_refused(tmp_path):
    r = run(BOX, "-o", tmp_path / "out.h5", "--device", "cpu", "--replicas", 2)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "replicas run on the GPU engine only" in lines[0], r.stderr
    assert list(tmp_path.iterdir()) == []


def test_bench_gpu_host_times_the_box():
    c = [str(BIN), "bench", str(BOX), "--device", "gpu-host", "--settle", "0", "--seconds", "0.01",
         "--repeat", "2", "--json"]
    for s in SETS:
        c += ["--set", s]
    r = subprocess.run(c, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    (res,) = json.loads(r.stdout)
    assert res["device"] == "gpu-host" and res["backend"] == "host" and res["replicas"] == 1
    assert res["steps"] == 50 and res["particles"] > 31
    assert res["particle_steps_per_second"] > 0 and len(res["rates"]) == 2
    assert res["neighbor_builds"] >= 0
    r = subprocess.run(c + ["--replicas", "3"], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    (rep,) = json.loads(r.stdout)
    assert rep["replicas"] == 3 and rep["particles"] == 3 * res["particles"]
