"""`granular run --device gpu-host`: the GPU engine (the CPU engine's run
loop, output, health checks and checkpoints, with the state stepped by the
GPU kernels) with its kernels built by the host compiler, run on the CPU
(docs/gpu.md). It writes the CPU engine's output schema and follows the CPU
engine to rounding; a resumed run repeats the uninterrupted one bit for bit;
replica k of `--replicas K` is, bit for bit, the single run with seed + k;
a capped drum follows the CPU engine too; an unstable run stops with the
CPU engine's message and writes no NaN; the scenes the GPU engine does not
run (the particles scenes) are refused; `granular bench` times it. The
shaken box's run: tests/python/test_gpu_box_run.py."""
import json
import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
DRUM = ROOT / "scenes" / "drum" / "A.toml"
CAPPED = ROOT / "scenes" / "drum" / "R.toml"
PARTICLES = ROOT / "scenes" / "impacts" / "wall_normal.toml"
# Drum #A shortened to L = 8 (264 particles): the initial collapse, with
# frames every 0.1 rotation and profiles every 0.02.
SETS = ["drum.length=8", "run.rotations=0.4", "run.snapshot_every=0.1", "run.profile_every=0.02"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def run(*args, sets=SETS, threads=2):
    c = [str(BIN), "run", str(args[0]), "-q", "--threads", str(threads), *map(str, args[1:])]
    for s in sets:
        c += ["--set", s]
    return subprocess.run(c, capture_output=True, text=True, timeout=600, cwd=ROOT)


def datasets(path):
    out = {}
    with h5py.File(path, "r") as h5:
        h5.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def attributes(path):
    out = {}
    with h5py.File(path, "r") as h5:
        def take(name, obj):
            for k in obj.attrs:
                out[f"{name}:{k}"] = obj.attrs[k]
        take("/", h5)
        h5.visititems(take)
    return out


def assert_bitwise_equal(a, b):
    da, db = datasets(a), datasets(b)
    assert sorted(da) == sorted(db)
    for name in da:
        assert da[name].shape == db[name].shape, name
        assert da[name].tobytes() == db[name].tobytes(), f"{name} differs"
    aa, ab = attributes(a), attributes(b)
    assert sorted(aa) == sorted(ab)
    for name in aa:
        assert np.array_equal(aa[name], ab[name]), f"attribute {name} differs"


def by_id(d, name):
    """Frame dataset `name` with each frame's rows in id order."""
    order = np.argsort(d["frames/id"], axis=-1)
    return np.take_along_axis(d[name], order[..., None] if d[name].ndim == 3 else order, axis=1)


@pytest.fixture(scope="module")
def cpu_and_gpu_host(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gpu_host")
    cpu, gpu = tmp / "cpu.h5", tmp / "gpu.h5"
    r = run(DRUM, "-o", cpu)
    assert r.returncode == 0, r.stderr
    r = run(DRUM, "-o", gpu, "--device", "gpu-host")
    assert r.returncode == 0, r.stderr
    assert "device gpu-host" in r.stderr
    return cpu, gpu


def assert_same_schema(cpu, gpu):
    """The GPU engine's output has every dataset of the CPU engine's, with its
    shape and type, and the same attributes (the engine version aside);
    returns both files' datasets."""
    dc, dg = datasets(cpu), datasets(gpu)
    assert sorted(dc) == sorted(dg)
    for name in dc:
        assert dc[name].shape == dg[name].shape, name
        assert dc[name].dtype == dg[name].dtype, name
    ac, ag = attributes(cpu), attributes(gpu)
    assert sorted(ac) == sorted(ag)
    for name in ac:
        if name != "/:engine_version":
            assert np.array_equal(ac[name], ag[name]), f"attribute {name} differs"
    assert np.isfinite(dg["frames/position"]).all()
    return dc, dg


def test_gpu_host_writes_the_cpu_schema(cpu_and_gpu_host):
    assert_same_schema(*cpu_and_gpu_host)


def test_gpu_host_follows_the_cpu_engine(cpu_and_gpu_host):
    """Frames matched by id: the two engines sum a particle's contacts in
    another order, so they agree to rounding, which the collisions of the
    collapse amplify; after 0.4 rotations (503 steps) positions agree to
    1e-9 of the drum's radius, and the profiles and Coulomb census to 1e-9."""
    dc, dg = (datasets(p) for p in cpu_and_gpu_host)
    assert np.array_equal(dc["frames/time"], dg["frames/time"])
    xc, xg = by_id(dc, "frames/position"), by_id(dg, "frames/position")
    assert np.abs(xc[-1] - xc[0]).max() > 1.0  # the grains moved
    dx = np.abs(xg - xc)
    dx[..., 1] = np.minimum(dx[..., 1], 8.0 - dx[..., 1])  # across the periodic end
    print(f"largest position difference {dx.max():.3g}")
    assert dx.max() < 1e-8
    for name in dc:
        if name.startswith(("profiles/", "coulomb/")):
            np.testing.assert_allclose(dg[name], dc[name], rtol=1e-9, atol=1e-12, err_msg=name)


def test_gpu_host_resumes_bitwise(tmp_path):
    """0.2 rotations, then --resume to 0.4: every dataset is the
    uninterrupted 0.4-rotation run's, bit for bit (checkpoints hold the
    stepper's particle order and its neighbour list's reference positions)."""
    whole, parts = tmp_path / "whole.h5", tmp_path / "parts.h5"
    assert run(DRUM, "-o", whole, "--device", "gpu-host").returncode == 0
    first = [s if not s.startswith("run.rotations") else "run.rotations=0.2" for s in SETS]
    r = run(DRUM, "-o", parts, "--device", "gpu-host", "--checkpoint-steps", 100, sets=first)
    assert r.returncode == 0, r.stderr
    assert Path(str(parts) + ".ckpt").exists()
    r = run(DRUM, "-o", parts, "--device", "gpu-host", "--resume")
    assert r.returncode == 0, r.stderr
    assert "resuming from step 251" in r.stderr
    dw, dp = datasets(whole), datasets(parts)
    assert sorted(dw) == sorted(dp)
    for name in dw:
        assert dw[name].tobytes() == dp[name].tobytes(), f"{name} differs"


def test_checkpoints_resume_on_their_own_engine_only(tmp_path):
    for wrote, other in (("gpu-host", "cpu"), ("cpu", "gpu-host")):
        out = tmp_path / f"{wrote}.h5"
        assert run(DRUM, "-o", out, "--device", wrote).returncode == 0
        r = run(DRUM, "-o", out, "--device", other, "--resume")
        assert r.returncode == 2, r.stderr
        assert "resume it with --device" in r.stderr, r.stderr


def test_replica_k_is_the_single_run_with_seed_plus_k(tmp_path):
    out = tmp_path / "ens.h5"
    r = run(DRUM, "-o", out, "--device", "gpu-host", "--replicas", 3)
    assert r.returncode == 0, r.stderr
    names = sorted(p.name for p in tmp_path.glob("*.h5"))
    assert names == ["ens_r00.h5", "ens_r01.h5", "ens_r02.h5"]
    single = tmp_path / "single" / "seed3.h5"
    single.parent.mkdir()
    r = run(DRUM, "-o", single, "--device", "gpu-host", sets=SETS + ["particles.seed=3"])
    assert r.returncode == 0, r.stderr
    assert_bitwise_equal(tmp_path / "ens_r02.h5", single)
    # the replicas are different drums
    a, b = datasets(tmp_path / "ens_r00.h5"), datasets(tmp_path / "ens_r01.h5")
    assert a["frames/position"].tobytes() != b["frames/position"].tobytes()


def test_replicas_resume_bitwise(tmp_path):
    whole, parts = tmp_path / "whole" / "e.h5", tmp_path / "parts" / "e.h5"
    whole.parent.mkdir()
    parts.parent.mkdir()
    assert run(DRUM, "-o", whole, "--device", "gpu-host", "--replicas", 2).returncode == 0
    first = [s if not s.startswith("run.rotations") else "run.rotations=0.2" for s in SETS]
    assert run(DRUM, "-o", parts, "--device", "gpu-host", "--replicas", 2, sets=first).returncode == 0
    r = run(DRUM, "-o", parts, "--device", "gpu-host", "--replicas", 2, "--resume")
    assert r.returncode == 0, r.stderr
    for k in ("e_r00.h5", "e_r01.h5"):
        dw, dp = datasets(whole.parent / k), datasets(parts.parent / k)
        for name in dw:
            assert dw[name].tobytes() == dp[name].tobytes(), f"{k} {name} differs"


def test_unstable_run_stops_with_the_cpu_message_and_no_nan(tmp_path):
    """A step 3 times the default: both engines stop at step 38 with status
    3 and the same message (step, time, particle, cause: the CPU engine's
    check names the culprit from the state the GPU engine downloads); the
    frames written before hold no NaN (a profile's empty slice is NaN by
    design)."""
    bad = SETS + ["integrator.dt=0.03", "run.snapshot_every=0.01"]
    errors = {}
    for device in ("cpu", "gpu-host"):
        out = tmp_path / f"{device}.h5"
        r = run(DRUM, "-o", out, "--device", device, sets=bad)
        assert r.returncode == 3, r.stderr
        (errors[device],) = [ln for ln in r.stderr.splitlines() if ln.startswith("error: ")]
        d = datasets(out)
        assert d["frames/position"].shape[0] > 5
        for name, v in d.items():
            if name.startswith("frames/") and v.dtype.kind == "f":
                assert not np.isnan(v).any(), f"{device}: {name} holds NaN"
    assert errors["cpu"].startswith("error: simulation unstable at step 38 (t = 1.14): particle id ")
    assert "Likely cause: integrator.dt = 0.03" in errors["cpu"]
    assert errors["gpu-host"] == errors["cpu"]


def test_capped_drum_on_gpu_host_follows_the_cpu_engine(tmp_path):
    """Drum #R (capped ends, two sizes) shortened to L = 8 for 0.4
    rotations, both engines: the caps' contacts as well as the cylinder's
    and the pairs', so again agreement to rounding, amplified by the
    collapse; positions agree to 1e-9 of the drum's radius, the profiles and
    Coulomb census to 1e-9."""
    out = {}
    for device in ("cpu", "gpu-host"):
        out[device] = tmp_path / f"{device}.h5"
        r = run(CAPPED, "-o", out[device], "--device", device)
        assert r.returncode == 0, r.stderr
    dc, dg = datasets(out["cpu"]), datasets(out["gpu-host"])
    assert sorted(dc) == sorted(dg)
    assert np.array_equal(dc["frames/time"], dg["frames/time"])
    xc, xg = by_id(dc, "frames/position"), by_id(dg, "frames/position")
    assert np.abs(xc[-1] - xc[0]).max() > 1.0  # the grains moved
    assert np.abs(xc[..., 1]).max() < 4.0  # held between the caps at y = -4 and 4
    dx = np.abs(xg - xc)  # no periodic axis: no minimum image
    print(f"largest position difference {dx.max():.3g}")
    assert dx.max() < 1e-8
    for name in dc:
        if name.startswith(("profiles/", "coulomb/")):
            np.testing.assert_allclose(dg[name], dc[name], rtol=1e-9, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("device", ["gpu", "gpu-host"])
def test_scenes_the_gpu_engine_does_not_run_are_refused(tmp_path, device):
    """A particles scene: the GPU engine runs drums and the shaken box."""
    r = run(PARTICLES, "-o", tmp_path / "out.h5", "--device", device, sets=[])
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: --device {device}: "), r.stderr
    assert "drum and shaken-box scenes only" in lines[0] and lines[0].endswith("run it with --device cpu"), lines[0]
    assert list(tmp_path.iterdir()) == []


def test_replicas_need_the_gpu_engine(tmp_path):
    r = run(DRUM, "-o", tmp_path / "out.h5", "--replicas", 2)
    assert r.returncode == 2
    assert "error: --replicas: replicas run on the GPU engine only" in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_bench_gpu_host_reports_the_cpu_bench_fields():
    c = [str(BIN), "bench", str(DRUM), "--device", "gpu-host", "--replicas", "2", "--settle", "0",
         "--rotations", "0.05", "--repeat", "2", "--json", "--set", "drum.length=8"]
    r = subprocess.run(c, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    (res,) = json.loads(r.stdout)
    assert res["device"] == "gpu-host" and res["backend"] == "host" and res["replicas"] == 2
    assert res["particles"] == 2 * 264
    assert res["steps"] == round(0.05 * 2 * np.pi / 0.5 / 0.01)
    assert res["particle_steps_per_second"] > 0 and len(res["rates"]) == 2
    assert res["min"] <= res["particle_steps_per_second"] <= res["max"]
    assert res["neighbor_builds"] >= 1
    assert res["memory_order"] == "cells"


def test_bench_memory_order_ids_on_the_gpu_engine_only():
    c = [str(BIN), "bench", str(DRUM), "--device", "gpu-host", "--gpu-memory-order", "ids", "--settle", "0",
         "--rotations", "0.05", "--repeat", "1", "--json", "--set", "drum.length=8"]
    r = subprocess.run(c, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    (res,) = json.loads(r.stdout)
    assert res["memory_order"] == "ids" and res["neighbor_builds"] >= 1
    c = [str(BIN), "bench", str(DRUM), "--gpu-memory-order", "ids", "--set", "drum.length=8"]
    r = subprocess.run(c, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 2
    assert r.stderr.strip() == "error: --gpu-memory-order: the GPU engine's memory order (--device gpu or gpu-host)"


def test_sigterm_checkpoints_every_replica_and_resumes_bitwise(tmp_path):
    """SIGTERM during a run of 2 replicas: both write their checkpoint, the
    run exits 143, and --resume finishes both into the uninterrupted run's
    outputs, bit for bit."""
    import signal
    import time

    sets = ["drum.length=8", "run.rotations=3", "run.snapshot_every=0.25", "run.profile_every=0.05"]
    whole, parts = tmp_path / "whole" / "e.h5", tmp_path / "parts" / "e.h5"
    whole.parent.mkdir()
    parts.parent.mkdir()
    assert run(DRUM, "-o", whole, "--device", "gpu-host", "--replicas", 2, sets=sets).returncode == 0
    c = [str(BIN), "run", str(DRUM), "-q", "--threads", "2", "-o", str(parts), "--device", "gpu-host",
         "--replicas", "2", "--checkpoint-steps", "300"]
    for s in sets:
        c += ["--set", s]
    p = subprocess.Popen(c, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    first = parts.parent / "e_r00.h5.ckpt"
    deadline = time.monotonic() + 120
    while not first.exists():
        assert p.poll() is None, p.stderr.read()
        assert time.monotonic() < deadline
        time.sleep(0.01)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 143, err
    assert "stopped: SIGTERM at step" in err, err
    assert (parts.parent / "e_r01.h5.ckpt").exists()
    r = run(DRUM, "-o", parts, "--device", "gpu-host", "--replicas", 2, "--resume", sets=sets)
    assert r.returncode == 0, r.stderr
    for k in ("e_r00.h5", "e_r01.h5"):
        dw, dp = datasets(whole.parent / k), datasets(parts.parent / k)
        assert sorted(dw) == sorted(dp)
        for name in dw:
            assert dw[name].tobytes() == dp[name].tobytes(), f"{k} {name} differs"
