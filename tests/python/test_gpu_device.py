"""`granular run --device`: cpu is the default and runs; gpu, on a machine
or build without CUDA, is refused before anything is written, with status 2
and one line naming the reason (docs/gpu.md, docs/errors.md): a build
without CUDA, or no visible CUDA device. (gpu-host, the GPU engine run on
the CPU: tests/python/test_gpu_run.py.)"""
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
SCENE = "scenes/drum/A.toml"
SHORT = ["--set", "drum.length=8", "--set", "run.rotations=0.002", "-q"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def granular(*args):
    return subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True, timeout=300, cwd=ROOT)


REASONS = ("this granular was built without CUDA", "no CUDA device is visible")


def cuda_device_visible():
    return Path("/dev/nvidia0").exists()


@pytest.mark.skipif(cuda_device_visible(), reason="a CUDA device is visible: --device gpu runs")
def test_gpu_is_refused_with_one_line_and_no_output(tmp_path):
    out = tmp_path / "out.h5"
    r = granular("run", SCENE, "--device", "gpu", "-o", out, *SHORT)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("error: --device gpu: "), lines[0]
    assert any(reason in lines[0] for reason in REASONS), lines[0]
    assert lines[0].endswith("run on the CPU with --device cpu")
    assert r.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_cpu_is_the_default_and_runs(tmp_path):
    for extra in ([], ["--device", "cpu"]):
        out = tmp_path / f"out{len(extra)}.h5"
        r = granular("run", SCENE, "-o", out, *SHORT, *extra)
        assert r.returncode == 0, r.stderr
        assert out.exists()


def test_another_device_is_a_command_line_error(tmp_path):
    r = granular("run", SCENE, "--device", "tpu", "-o", tmp_path / "out.h5", *SHORT)
    assert r.returncode == 2
    assert "--device: tpu not in {cpu,gpu,gpu-host}" in r.stderr
    assert list(tmp_path.iterdir()) == []
