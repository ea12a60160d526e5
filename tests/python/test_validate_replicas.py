"""The native drum and box rows on the GPU engine (compare validate --device):
a row's seeds run as replicas of one process, replica k filed as seed first+k, which
is the run of that seed alone on the same device; a second pass finds every
run in the cache. Checked with the GPU engine's host build (gpu-host), which
this machine has whether or not it has a GPU."""
import json
import subprocess

import h5py
import numpy as np
import pytest

from compare.validate import (Case, SUITES, granular_bin, jobs_of, native_device, replica_batches, run_all)


@pytest.fixture
def tiny_drums(monkeypatch):
    case = Case("tinyrep", "drum", "scenes/drum/A.toml",
                ["drum.length=8", "run.rotations=0.02", "run.snapshot_every=0.01", "run.profile_every=0.01"],
                [1, 2, 3, 5], ["native-paper", "lammps"], timeout=120)
    monkeypatch.setitem(SUITES, "tinyrep", [case])
    return "tinyrep"


def test_batches_are_consecutive_seeds_of_one_native_row(tiny_drums, tmp_path):
    jobs = jobs_of(tiny_drums, tmp_path)
    assert replica_batches(jobs, "cpu") == []
    batches = replica_batches(jobs, "gpu-host")
    # LAMMPS stays out; seeds 1-3 share a process, 5 is on its own.
    assert [[j.seed for j in b] for b in batches] == [[1, 2, 3], [5]]
    assert all(j.row == "native-paper" for b in batches for j in b)


def test_replica_k_is_its_seed_run_alone_and_is_cached(tiny_drums, tmp_path):
    jobs = [j for j in jobs_of(tiny_drums, tmp_path) if j.engine == "native"]
    log = []
    metas = run_all(jobs, lanes=1, log=log.append, device="gpu-host")
    assert [m["returncode"] for m in metas] == [0, 0, 0, 0], log
    assert [(m["replicas"], m["replica"]) for m in metas] == [(3, 0), (3, 1), (3, 2), (1, 0)]
    assert all(j.path.exists() and json.loads(j.path.with_suffix(".json").read_text())["device"] == "gpu-host"
               for j in jobs)
    assert not list((tmp_path / "runs").glob("*partial*")), "a replica file was left behind"
    # Seed 2 alone on the same device: the same bits as replica 1.
    alone = tmp_path / "alone.h5"
    cmd = jobs[1].command(alone) + ["--device", "gpu-host"]
    subprocess.run(cmd, check=True, capture_output=True)
    with h5py.File(jobs[1].path) as a, h5py.File(alone) as b, h5py.File(jobs[0].path) as other:
        assert a["frames/position"].shape == b["frames/position"].shape
        assert np.array_equal(a["frames/position"][()], b["frames/position"][()])
        assert not np.array_equal(a["frames/position"][()], other["frames/position"][()])
    again = run_all(jobs, lanes=1, log=log.append, device="gpu-host")
    assert all(m["cached"] for m in again)


def test_auto_is_the_cpu_without_a_visible_gpu():
    r = subprocess.run([str(granular_bin()), "devices", "--json"], capture_output=True, text=True, check=True)
    expect = "gpu" if json.loads(r.stdout)["gpu"]["available"] else "cpu"
    assert native_device("auto") == expect
    assert native_device("gpu-host") == "gpu-host"


@pytest.fixture
def tiny_boxes(monkeypatch):
    case = Case("tinyboxrep", "box", "scenes/box/f3.0_big.toml",
                ["box.width=12", "box.wall_height=14", "particles.count=30", "big.radius=2", "big.gap=1",
                 "run.settle=0.02", "shaking.startup_cycles=0", "run.duration=0.02"],
                [1, 2], ["native-leapfrog", "lammps"], frequencies=[3.0], timeout=120)
    monkeypatch.setitem(SUITES, "tinyboxrep", [case])
    return "tinyboxrep"


def test_box_replica_k_is_its_seed_run_alone(tiny_boxes, tmp_path):
    """A box row's seeds share one GPU engine process too (replica k filed as
    seed first + k, the run of that seed alone on the same device)."""
    jobs = [j for j in jobs_of(tiny_boxes, tmp_path) if j.engine == "native"]
    assert [[j.seed for j in b] for b in replica_batches(jobs, "gpu-host")] == [[1, 2]]
    log = []
    metas = run_all(jobs, lanes=1, log=log.append, device="gpu-host")
    assert [m["returncode"] for m in metas] == [0, 0], log
    assert [(m["replicas"], m["replica"]) for m in metas] == [(2, 0), (2, 1)]
    alone = tmp_path / "alone.h5"
    subprocess.run(jobs[1].command(alone) + ["--device", "gpu-host"], check=True, capture_output=True)
    with h5py.File(jobs[1].path) as a, h5py.File(alone) as b, h5py.File(jobs[0].path) as other:
        assert np.array_equal(a["frames/position"][()], b["frames/position"][()])
        assert not np.array_equal(a["frames/position"][()], other["frames/position"][()])
