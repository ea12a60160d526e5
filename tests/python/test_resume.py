"""Checkpoint, interruption and restart of real runs of the native engine.

A run stopped by SIGINT or SIGTERM writes a checkpoint and exits 130/143; a
run killed with SIGKILL at any moment leaves an output file that opens and
holds, bit for bit, the frames of the uninterrupted run up to where it died;
``--resume`` then continues either into an output whose every dataset is bit
for bit the uninterrupted run's (same thread count). And ``--resume`` refuses,
with exit status 2 and a message, what it cannot honour.
"""
import os
import random
import signal
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from compare.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
DRUM = ROOT / "scenes" / "drum" / "A.toml"
BOX = ROOT / "scenes" / "box" / "f3.0_big.toml"
# ~18k steps of a 528-particle drum: a few seconds, 15 frames, 351 profiles
# (output every 50 steps, so that a kill often lands in a write).
DRUM_SETS = ["drum.length=16", "run.rotations=7", "run.snapshot_every=0.5", "run.profile_every=0.02"]
BOX_SETS = ["particles.count=300", "box.width=30", "run.settle=0.2", "run.duration=1.2"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def cmd(scene, sets, out, *extra):
    c = [str(BIN), "run", str(scene), "-o", str(out), "-q", "--threads", "2"]
    for s in sets:
        c += ["--set", s]
    return c + list(map(str, extra))


def run(scene, sets, out, *extra):
    return subprocess.run(cmd(scene, sets, out, *extra), capture_output=True, text=True, timeout=600)


def datasets(path):
    out = {}
    with h5py.File(path, "r") as h5:
        h5.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def attributes(path, skip=()):
    """Every attribute of the file and of its groups and datasets, read back
    (a damaged one raises), by "object:name"."""
    out = {}
    with h5py.File(path, "r") as h5:
        def take(name, obj):
            for k in obj.attrs:
                if k not in skip:
                    out[f"{name}:{k}"] = obj.attrs[k]
        take("/", h5)
        h5.visititems(take)
    return out


def assert_bitwise_equal(a, b, skip_attrs=()):
    da, db = datasets(a), datasets(b)
    assert sorted(da) == sorted(db)
    for name in da:
        x, y = da[name], db[name]
        assert x.shape == y.shape, f"{name}: {x.shape} vs {y.shape}"
        assert x.tobytes() == y.tobytes(), f"{name} differs"
    aa, ab = attributes(a, skip_attrs), attributes(b, skip_attrs)
    assert sorted(aa) == sorted(ab)
    for name in aa:
        assert np.array_equal(aa[name], ab[name]), f"attribute {name} differs"


def uninterrupted(tmp_path_factory, scene, sets, name):
    out = tmp_path_factory.mktemp("ref") / name
    r = run(scene, sets, out)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="module")
def drum_ref(tmp_path_factory):
    return uninterrupted(tmp_path_factory, DRUM, DRUM_SETS, "drum.h5")


@pytest.fixture(scope="module")
def box_ref(tmp_path_factory):
    return uninterrupted(tmp_path_factory, BOX, BOX_SETS, "box.h5")


def start_and_wait_for_checkpoint(scene, sets, out, *extra):
    """Start a run; return it once its first checkpoint exists."""
    p = subprocess.Popen(cmd(scene, sets, out, *extra), stderr=subprocess.PIPE, text=True)
    ckpt = Path(str(out) + ".ckpt")
    deadline = time.monotonic() + 120
    while not ckpt.exists():
        assert p.poll() is None, f"the run ended before its first checkpoint: {p.stderr.read()}"
        assert time.monotonic() < deadline
        time.sleep(0.01)
    return p


@pytest.mark.parametrize("sig,status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_checkpoints_stops_and_resumes_bitwise(tmp_path, drum_ref, sig, status):
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(DRUM, DRUM_SETS, out, "--checkpoint-steps", 2000)
    p.send_signal(sig)
    _, err = p.communicate(timeout=120)
    assert p.returncode == status, err
    name = "SIGINT" if sig == signal.SIGINT else "SIGTERM"
    assert f"stopped: {name} at step" in err and "continue with --resume" in err, err
    stopped = read_run(out)
    assert 0 < stopped.frames.n_frames < read_run(drum_ref).frames.n_frames
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 0, r.stderr
    assert "resuming from step" in r.stderr
    assert_bitwise_equal(drum_ref, out)


def test_sigint_with_no_periodic_checkpoints_still_checkpoints(tmp_path, drum_ref):
    out = tmp_path / "drum.h5"
    p = subprocess.Popen(cmd(DRUM, DRUM_SETS, out, "--checkpoint-every", 0), stderr=subprocess.PIPE, text=True)
    # wait until the run is under way (its output holds the first frame)
    deadline = time.monotonic() + 60
    while not (out.exists() and out.stat().st_size > 0):
        assert time.monotonic() < deadline and p.poll() is None
        time.sleep(0.01)
    time.sleep(0.3)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    if p.returncode == 0:
        pytest.skip("the run finished before the signal arrived")
    assert p.returncode == 130, err
    assert run(DRUM, DRUM_SETS, out, "--resume").returncode == 0
    assert_bitwise_equal(drum_ref, out)


def test_sigkill_at_random_moments(tmp_path, drum_ref):
    """Killed anywhere (frames every 0.5 rotations, checkpoints every 1500
    steps, profiles every 50): the file opens, its complete frames are the reference's, and the
    resumed run is the reference bit for bit."""
    ref = read_run(drum_ref)
    rng = random.Random(20261121)
    for trial in range(6):
        out = tmp_path / f"killed{trial}.h5"
        p = start_and_wait_for_checkpoint(DRUM, DRUM_SETS, out, "--checkpoint-steps", 1500)
        time.sleep(rng.uniform(0.0, 1.5))
        p.kill()
        p.communicate(timeout=60)
        if p.returncode == 0:
            continue  # finished before the kill: nothing to test this time
        killed = read_run(out)  # opens, and holds only complete frames
        n = killed.frames.n_frames
        assert n >= 1
        for field in ("time", "position", "velocity", "angular_velocity"):
            got = getattr(killed.frames, field)
            want = getattr(ref.frames, field)[:n]
            assert got.tobytes() == want.tobytes(), f"trial {trial}: frames/{field}"
        r = run(DRUM, DRUM_SETS, out, "--resume")
        assert r.returncode == 0, r.stderr
        assert_bitwise_equal(drum_ref, out)


def test_box_gear_resumes_bitwise(tmp_path, box_ref):
    out = tmp_path / "box.h5"
    p = start_and_wait_for_checkpoint(BOX, BOX_SETS, out, "--checkpoint-steps", 5000)
    p.kill()
    p.communicate(timeout=60)
    assert p.returncode == -signal.SIGKILL
    r = run(BOX, BOX_SETS, out, "--resume")
    assert r.returncode == 0, r.stderr
    assert_bitwise_equal(box_ref, out)


def test_finished_run_resumes_to_nothing(tmp_path, drum_ref):
    out = tmp_path / "drum.h5"
    assert run(DRUM, DRUM_SETS, out).returncode == 0
    before = datasets(out)
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 0, r.stderr
    assert "done: 0 steps" in r.stderr
    after = datasets(out)
    assert all(before[k].tobytes() == after[k].tobytes() for k in before)


def test_resume_may_lengthen_the_run(tmp_path, drum_ref):
    """run.rotations may grow on --resume: the first 7 rotations are the
    reference's, and the run goes on to 9."""
    out = tmp_path / "drum.h5"
    assert run(DRUM, DRUM_SETS, out).returncode == 0
    longer = DRUM_SETS[:-3] + ["run.rotations=9"] + DRUM_SETS[-2:]
    r = run(DRUM, longer, out, "--resume")
    assert r.returncode == 0, r.stderr
    got, ref = read_run(out), read_run(drum_ref)
    n = ref.frames.n_frames
    assert got.frames.position[:n].tobytes() == ref.frames.position.tobytes()
    assert got.frames.time[-1] / got.rotation_period == pytest.approx(9.0, abs=1e-3)


def test_resume_refusals(tmp_path, drum_ref):
    out = tmp_path / "drum.h5"
    # nothing to resume
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 2 and "no output file to resume" in r.stderr
    assert not out.exists()
    # an output without its checkpoint (e.g. written before checkpoints existed)
    assert run(DRUM, DRUM_SETS, out).returncode == 0
    Path(str(out) + ".ckpt").unlink()
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 2 and "no checkpoint to resume from" in r.stderr, r.stderr
    # another scene: the key is named, the output is untouched
    assert run(DRUM, DRUM_SETS, out, "--force").returncode == 0
    before = datasets(out)
    r = run(DRUM, DRUM_SETS + ["friction.gamma_s_ss=3"], out, "--resume")
    assert r.returncode == 2 and "friction.gamma_s_ss" in r.stderr, r.stderr
    assert all(before[k].tobytes() == v.tobytes() for k, v in datasets(out).items())
    # --resume and --force contradict each other
    r = run(DRUM, DRUM_SETS, out, "--resume", "--force")
    assert r.returncode == 2 and "excludes" in r.stderr, r.stderr
    # a damaged checkpoint is named
    Path(str(out) + ".ckpt").write_text("garbage")
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 2 and "damaged checkpoint" in r.stderr and ".ckpt" in r.stderr, r.stderr


def test_other_thread_count_warns_and_continues(tmp_path, drum_ref):
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(DRUM, DRUM_SETS, out, "--checkpoint-steps", 2000)
    p.kill()
    p.communicate(timeout=60)
    c = cmd(DRUM, DRUM_SETS, out, "--resume")
    c[c.index("--threads") + 1] = "1"
    r = subprocess.run(c, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "statistically, not bitwise" in r.stderr
    got, ref = read_run(out), read_run(drum_ref)
    assert got.frames.n_frames == ref.frames.n_frames
    assert np.array_equal(got.frames.time, ref.frames.time)
    assert attributes(out, skip=("threads",)).keys() == attributes(drum_ref, skip=("threads",)).keys()
    assert got.attrs["threads"] == 1


def test_a_killed_output_is_only_read_on_resume(tmp_path, drum_ref):
    """HDF5 cannot safely write again into a file whose writer was killed, so
    --resume copies its rows up to the checkpoint into a new file that
    replaces it: the killed file's bytes (kept here under a second hard link)
    are never written, and no temporary file is left."""
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(DRUM, DRUM_SETS, out, "--checkpoint-steps", 2000)
    time.sleep(0.2)
    p.kill()
    p.communicate(timeout=60)
    if p.returncode == 0:
        pytest.skip("the run finished before the kill")
    kept = tmp_path / "kept.h5"
    os.link(out, kept)
    before = kept.read_bytes()
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 0, r.stderr
    assert kept.read_bytes() == before
    assert not os.path.samefile(out, kept)
    assert not Path(str(out) + ".resuming").exists()
    assert_bitwise_equal(drum_ref, out)


def test_a_resume_that_fails_leaves_the_output_as_it_was(tmp_path, drum_ref):
    """An output with fewer rows than its checkpoint records (here: cut back
    by hand) is refused with the dataset named; the output is untouched and no
    temporary file is left."""
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(DRUM, DRUM_SETS, out, "--checkpoint-steps", 2000)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 143, err
    with h5py.File(out, "r+") as h5:
        h5["profile/time"].resize((1,))
    before = out.read_bytes()
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 1, r.stderr
    assert "profile/time" in r.stderr and "fewer rows than the checkpoint recorded" in r.stderr, r.stderr
    assert out.read_bytes() == before
    assert not Path(str(out) + ".resuming").exists()


def test_resume_of_a_file_in_the_pre_swmr_format(tmp_path, drum_ref):
    """Outputs written before the switch to single-writer/multiple-reader mode
    have a version-0 superblock; --resume carries their rows into a file in
    the current format (version-3 superblock) and matches the reference."""
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(DRUM, DRUM_SETS, out, "--checkpoint-steps", 2000)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 143, err
    old = tmp_path / "old.h5"
    with h5py.File(out, "r") as src, h5py.File(old, "w", libver="earliest") as dst:
        for name in src:
            src.copy(src[name], dst, name=name)
        for k, v in src.attrs.items():
            dst.attrs[k] = v
    with open(old, "rb") as f:
        assert f.read(9)[8] == 0, "the copy should have a version-0 superblock"
    os.replace(old, out)
    r = run(DRUM, DRUM_SETS, out, "--resume")
    assert r.returncode == 0, r.stderr
    with open(out, "rb") as f:
        assert f.read(9)[8] == 3
    assert_bitwise_equal(drum_ref, out)


def test_checkpoint_from_before_a_scene_key_existed(tmp_path, box_ref):
    """A checkpoint written before box.walls existed resumes at the value that
    reproduces it ("particles"), bit for bit, and only at that value."""
    import json
    out = tmp_path / "box.h5"
    p = start_and_wait_for_checkpoint(BOX, BOX_SETS, out, "--checkpoint-steps", 5000)
    p.kill()
    p.communicate(timeout=60)
    ckpt = Path(str(out) + ".ckpt")
    with h5py.File(ckpt, "r+") as h5:
        raw = h5.attrs["scene_json"]
        scene = json.loads(raw.decode() if isinstance(raw, bytes) else raw)
        assert scene["box"].pop("walls") == "particles"
        h5.attrs["scene_json"] = json.dumps(scene)
    r = run(BOX, BOX_SETS + ['box.walls="smooth"'], out, "--resume")
    assert r.returncode == 2, r.stderr
    assert "box.walls" in r.stderr and "existed" in r.stderr and '"particles"' in r.stderr, r.stderr
    r = run(BOX, BOX_SETS, out, "--resume")
    assert r.returncode == 0, r.stderr
    assert_bitwise_equal(box_ref, out)
