"""scripts/campaign.sh survives interruption: a job stopped by SIGTERM after
its first checkpoint is resumed by the next invocation and ends bit for bit
where an uninterrupted run ends; a finished job is skipped."""
import os
import signal
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
SCENE = ROOT / "scenes" / "drum" / "A.toml"
SETS = ["--set", "drum.length=32", "--set", "run.rotations=1.5", "--set", "run.snapshot_every=0.25",
        "--set", "run.profile_every=0.25", "--checkpoint-steps", "200"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def campaign(jobs, **kw):
    env = dict(os.environ, GRANULAR_BIN=str(BIN), CAMPAIGN_NICE="0")
    return subprocess.Popen(["bash", str(ROOT / "scripts" / "campaign.sh"), str(jobs), "1"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True, **kw)


def last_frame(path):
    with h5py.File(path, "r") as f:
        return f["frames/position"][-1], f["frames/time"][:]


def test_interrupted_job_resumes_to_the_same_end(tmp_path):
    ref = tmp_path / "ref.h5"
    subprocess.run([str(BIN), "run", str(SCENE), "-o", str(ref), "--threads", "1", "-q", *SETS], check=True,
                   capture_output=True, timeout=300)
    out = tmp_path / "runs" / "A.h5"
    jobs = tmp_path / "jobs.txt"
    jobs.write_text(f"# one job\n{out} {SCENE} {' '.join(SETS)}\n")
    p = campaign(jobs)
    deadline = time.time() + 120
    while not (out.parent / "A.h5.ckpt").exists() and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert (out.parent / "A.h5.ckpt").exists(), "no checkpoint before the deadline"
    os.killpg(p.pid, signal.SIGTERM)
    p.wait(timeout=60)
    if (out.parent / "A.h5.done").exists():
        pytest.skip("the job finished before it could be interrupted")
    # the next invocation resumes it
    p = campaign(jobs)
    p.wait(timeout=300)
    assert (out.parent / "A.h5.done").exists(), p.stderr.read()
    x, t = last_frame(out)
    x_ref, t_ref = last_frame(ref)
    np.testing.assert_array_equal(t, t_ref)
    np.testing.assert_array_equal(x, x_ref)
    # a finished job is skipped: the output is not touched again
    mtime = out.stat().st_mtime_ns
    p = campaign(jobs)
    p.wait(timeout=60)
    assert out.stat().st_mtime_ns == mtime


def test_campaign_status_lists_reached_rotations(tmp_path):
    """`compare campaign-status DIR` gives each Table I run's rotations reached
    against requested and its state, and the step check's runs after them."""
    runs = tmp_path / "runs"
    (runs / "step").mkdir(parents=True)
    common = [str(BIN), "run", str(SCENE), "--threads", "1", "-q", "--set", "drum.length=32",
              "--set", "run.snapshot_every=0.25", "--set", "run.profile_every=0.25"]
    subprocess.run(common + ["-o", str(runs / "C.h5"), "--set", "run.rotations=0.5"], check=True,
                   capture_output=True, timeout=300)
    (runs / "C.h5.done").touch()
    subprocess.run(common + ["-o", str(runs / "step" / "A_dt0.005_s1.h5"), "--set", "run.rotations=0.25"],
                   check=True, capture_output=True, timeout=300)
    r = subprocess.run(["/usr/bin/python3", "-m", "compare", "campaign-status", str(tmp_path)], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    rows = {ln.split()[0]: ln.split()[1:] for ln in r.stdout.splitlines()[1:]}
    assert rows["C"][:2] == ["0.5", "0.5"] and rows["C"][2] == "done"
    assert rows["A"][0] == "-" and "waiting" in rows["A"]
    step = rows["A_dt0.005_s1"]
    assert float(step[0]) == pytest.approx(0.25, abs=0.06) and step[1] == "0.25" and "running" in step
