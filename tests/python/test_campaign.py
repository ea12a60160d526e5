"""scripts/campaign.sh survives interruption: a job stopped by SIGTERM after
its first checkpoint is resumed by the next invocation and ends bit for bit
where an uninterrupted run ends; a finished job is skipped."""
import os
import re
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


def test_state_saved_while_running_resumes_elsewhere_to_the_same_end(tmp_path):
    """scripts/campaign_store.sh: the state of a job whose engine is writing is
    saved into the repository (committed), the engine goes on, and the saved
    state restored into another directory resumes to the end the uninterrupted
    run reaches, bit for bit."""
    repo = tmp_path / "repo"
    (repo / "scripts").mkdir(parents=True)
    (repo / "scripts" / "campaign_store.sh").write_bytes((ROOT / "scripts" / "campaign_store.sh").read_bytes())
    (repo / ".gitignore").write_bytes((ROOT / ".gitignore").read_bytes())
    git = ["git", "-C", str(repo), "-c", "user.name=test", "-c", "user.email=test@localhost"]
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    subprocess.run(git + ["add", "."], check=True)
    subprocess.run(git + ["commit", "-qm", "scripts"], check=True)
    job = tmp_path / "job"
    (job / "engine").mkdir(parents=True)
    (job / "engine" / "granular").symlink_to(BIN)
    (job / "COMMIT").write_text("0" * 40 + "\n")
    (job / "jobs.txt").write_text("one job\n")
    out = job / "runs" / "A.h5"
    out.parent.mkdir()
    sets = [s.replace("run.rotations=1.5", "run.rotations=4") for s in SETS]
    run = [str(job / "engine" / "granular"), "run", str(SCENE), "--threads", "1", "-q", *sets]
    p = subprocess.Popen(run + ["-o", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while not Path(f"{out}.ckpt").exists() and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    if p.poll() is not None:
        pytest.skip("the run finished before its state could be saved")
    env = dict(os.environ, GIT_AUTHOR_NAME="test", GIT_AUTHOR_EMAIL="test@localhost",
               GIT_COMMITTER_NAME="test", GIT_COMMITTER_EMAIL="test@localhost")
    s = subprocess.run(["bash", str(repo / "scripts" / "campaign_store.sh"), "save", "fake", str(job)],
                       capture_output=True, text=True, timeout=120, env=env)
    assert s.returncode == 0, s.stderr
    if p.poll() is None:  # the engine was paused for the copy, not left stopped
        with open(f"/proc/{p.pid}/stat") as f:
            assert f.read().split(")")[-1].split()[0] != "T"
    assert p.wait(timeout=300) == 0, p.stderr.read()
    tracked = subprocess.run(git + ["ls-files", "campaign/fake"], capture_output=True, text=True,
                             check=True).stdout.split()
    assert {"campaign/fake/COMMIT", "campaign/fake/jobs.txt", "campaign/fake/runs/A.h5",
            "campaign/fake/runs/A.h5.ckpt"} <= set(tracked)
    # restored on another machine: a directory without the job
    job2 = tmp_path / "job2"
    r = subprocess.run(["bash", str(repo / "scripts" / "campaign_store.sh"), "restore", "fake", str(job2)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert (job2 / "COMMIT").read_text() == (job / "COMMIT").read_text()
    out2 = job2 / "runs" / "A.h5"
    subprocess.run([str(BIN), "run", str(SCENE), "--threads", "1", "-q", *sets, "-o", str(out2), "--resume"],
                   check=True, capture_output=True, timeout=300)
    x, t = last_frame(out2)
    x_ref, t_ref = last_frame(out)
    np.testing.assert_array_equal(t, t_ref)
    np.testing.assert_array_equal(x, x_ref)


def test_stop_ends_the_jobs_processes_and_the_job_resumes(tmp_path):
    """scripts/campaign_store.sh stop: every process of the job's setsid group
    ends (the engine writes its checkpoint on SIGTERM), the test's own group
    is left alone, and the next start finishes the job from the checkpoint."""
    job = tmp_path / "job"
    out = job / "runs" / "A.h5"
    jobs = job / "jobs.txt"
    job.mkdir()
    sets = [s.replace("run.rotations=1.5", "run.rotations=3") for s in SETS]
    jobs.write_text(f"{out} {SCENE} {' '.join(sets)}\n")
    p = campaign(jobs)
    deadline = time.time() + 120
    while not Path(f"{out}.ckpt").exists() and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    if p.poll() is not None:
        pytest.skip("the job finished before it could be stopped")
    s = subprocess.run(["bash", str(ROOT / "scripts" / "campaign_store.sh"), "stop", "fake", str(job)],
                       capture_output=True, text=True, timeout=120)
    assert s.returncode == 0, s.stderr
    assert "fake stopped" in s.stdout
    p.wait(timeout=10)
    states = subprocess.run(["ps", "-o", "stat=", "--sid", str(p.pid)], capture_output=True, text=True).stdout
    assert [st for st in states.split() if not st.startswith("Z")] == []  # nothing left but the unreaped
    stopped = re.search(r"\(SID ([0-9 ]+)\)", s.stdout).group(1).split()
    assert str(os.getsid(0)) not in stopped and "0" not in stopped
    assert Path(f"{out}.ckpt").exists() and not Path(f"{out}.done").exists()
    again = subprocess.run(["bash", str(ROOT / "scripts" / "campaign_store.sh"), "stop", "fake", str(job)],
                           capture_output=True, text=True, timeout=60)
    assert again.returncode == 0 and "no fake job running" in again.stdout
    q = campaign(jobs)
    assert q.wait(timeout=600) == 0, q.stderr.read()
    assert Path(f"{out}.done").exists()
    assert "resum" in (job / "runs" / "A.log").read_text().lower()
    _, t = last_frame(out)
    assert t[-1] > 0
