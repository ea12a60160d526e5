"""The validation cache (compare/validate.py): a finished run is reused, a run
whose scene now resolves differently (a changed engine default) runs again, a
run cached before the check existed is adopted as it is, and a run cached
under a row's earlier name is found under its present one."""
import json
import os
import subprocess
import sys

import pytest

from compare import validate
from compare.validate import (Case, jobs_of, old_row_names, resolved_scene, run_job, same_resolution,
                              same_run_elsewhere, SUITES)


@pytest.fixture
def tiny_suite(monkeypatch):
    case = Case("tiny", "drum", "scenes/drum/A.toml",
                ["drum.length=8", "run.rotations=0.02", "run.snapshot_every=0.01", "run.profile_every=0.01"],
                [1], ["native-paper"], timeout=120)
    monkeypatch.setitem(SUITES, "tiny", [case])
    return "tiny"


def test_reused_then_stale_after_a_default_changes(tiny_suite, tmp_path):
    (job,) = jobs_of(tiny_suite, tmp_path)
    log = []
    first = run_job(job, log.append)
    assert first["returncode"] == 0 and not first["cached"], first
    dt = first["resolved_scene"]["integrator"]["dt"]
    assert first["resolved_scene"] == resolved_scene(job) and dt > 0
    again = run_job(job, log.append)
    assert again["cached"]
    # The engine's default step "changes": the stored resolution no longer matches.
    meta_path = job.path.with_suffix(".json")
    meta = json.loads(meta_path.read_text())
    meta["resolved_scene"]["integrator"]["dt"] = 2 * dt
    meta_path.write_text(json.dumps(meta))
    rerun = run_job(job, log.append)
    assert not rerun["cached"] and rerun["returncode"] == 0
    assert job.path.with_name(job.path.stem + ".stale.h5").exists()
    assert any("stale" in m for m in log), log
    assert json.loads(meta_path.read_text())["resolved_scene"]["integrator"]["dt"] == dt


def test_a_run_cached_before_the_check_is_adopted(tiny_suite, tmp_path):
    (job,) = jobs_of(tiny_suite, tmp_path)
    run_job(job)
    meta_path = job.path.with_suffix(".json")
    meta = json.loads(meta_path.read_text())
    del meta["resolved_scene"]
    meta_path.write_text(json.dumps(meta))
    m = run_job(job)
    assert m["cached"]
    assert "resolved_scene" in json.loads(meta_path.read_text())


def test_a_key_added_later_matches_only_at_its_old_behaviour(tiny_suite, tmp_path):
    (job,) = jobs_of(tiny_suite, tmp_path)
    now = resolved_scene(job)
    before = json.loads(json.dumps(now))
    del before["particles"]["rotation"]  # cached before particles.rotation existed
    assert same_resolution(before, now)
    now["particles"]["rotation"] = False
    assert not same_resolution(before, now)
    now["particles"]["rotation"] = True
    now["particles"]["seed"] = 2
    assert not same_resolution(before, now)


def test_a_run_is_found_under_another_key_when_it_resolved_the_same(tiny_suite, tmp_path, monkeypatch):
    (job,) = jobs_of(tiny_suite, tmp_path)
    first = run_job(job)
    assert not first["cached"]
    # The same scene with its step pinned at the value it resolved to: a new
    # key, the same resolved scene, so the run is reused, not repeated.
    case = SUITES[tiny_suite][0]
    dt = first["resolved_scene"]["integrator"]["dt"]
    monkeypatch.setattr(case, "sets", case.sets + [f"integrator.dt={dt}"])
    (pinned,) = jobs_of(tiny_suite, tmp_path)
    assert pinned.path != job.path
    log = []
    m = run_job(pinned, log.append)
    assert m["cached"] and m["same_as"] == job.path.name, m
    assert pinned.path.exists() and any("reused" in x for x in log)
    # a different step is a different run
    monkeypatch.setattr(case, "sets", case.sets[:-1] + [f"integrator.dt={dt / 2}"])
    (halved,) = jobs_of(tiny_suite, tmp_path)
    assert same_run_elsewhere(halved, resolved_scene(halved)) is None


def test_run_timed_counts_the_cpu_time_of_the_run_and_its_children():
    # A shell that runs a busy child: the child's CPU time is the run's, and a
    # sleeping run costs almost none however long it takes.
    busy = ["sh", "-c", f"{sys.executable} -c 'import time\nt=time.process_time()\nwhile time.process_time()-t<0.3: pass'"]
    rc, _, cpu = validate.run_timed(busy, 30)
    assert rc == 0 and 0.25 < cpu < 2.0
    rc, _, cpu = validate.run_timed(["sleep", "0.5"], 30)
    assert rc == 0 and cpu < 0.1


def test_run_timed_reports_a_timeout_and_a_failure(monkeypatch):
    # The run keeps the scheduler's share it starts with (the yield to
    # interactive work is tested on its own below): what is tested here is
    # the CPU-time limit, which a niced test run on a busy machine could
    # otherwise turn into the wall-clock one.
    monkeypatch.setattr(validate, "yield_like_this_process", lambda pid: None)
    rc, err, _ = validate.run_timed([sys.executable, "-c", "while True: pass"], 0.5)
    assert rc == -1 and "timed out" in err
    rc, err, _ = validate.run_timed(["sh", "-c", "echo broken >&2; exit 3"], 5)
    assert rc == 3 and "broken" in err


def test_a_key_the_engine_does_not_read_does_not_make_its_run_stale():
    # LAMMPS and YADE shake the box with their own integrators: a changed
    # integrator.kind leaves their runs valid, a changed step does not.
    old = {"integrator": {"kind": "gear", "dt": 2e-4}, "shaking": {"frequency": 3.0}}
    new = {"integrator": {"kind": "leapfrog", "dt": 2e-4}, "shaking": {"frequency": 3.0}}
    ignore = validate.NOT_READ[("lammps", "box")]
    assert same_resolution(old, new, ignore)
    assert not same_resolution(old, new)  # the native engine reads it
    assert not same_resolution(old, {"integrator": {"kind": "leapfrog", "dt": 5e-5}, "shaking": {"frequency": 3.0}},
                               ignore)
    assert old["integrator"]["kind"] == "gear"  # the stored resolution is left as it was


@pytest.fixture
def tiny_box(monkeypatch):
    # The box's two rows that name the integrator, a few hundredths of a second each.
    case = Case("tinybox", "box", "scenes/box/f3.0_big.toml", ["run.settle=0.02", "run.duration=0.02"],
                [1], ["native-leapfrog", "native-viscel"], frequencies=[3.0], timeout=120)
    monkeypatch.setitem(SUITES, "tinybox", [case])
    return "tinybox"


def cached_as_before(job, outdir):
    """Moves a finished run of `job` to the file and metadata a suite made
    before the box's integrator was called "leapfrog": row native-verlet,
    override integrator.kind="verlet", resolved scene with kind "verlet"."""
    old_row = job.row.replace("native-leapfrog", "native-verlet")
    old_sets = [x.replace('"leapfrog"', '"verlet"') for x in job.sets]
    old = validate._job(job.case, old_row, job.variant, job.seed, job.engine, old_sets, outdir)
    meta = json.loads(job.path.with_suffix(".json").read_text())
    meta["resolved_scene"]["integrator"]["kind"] = "verlet"
    meta["label"] = old.label
    os.replace(job.path, old.path)
    job.path.with_suffix(".json").unlink()
    old.path.with_suffix(".json").write_text(json.dumps(meta))
    return old


def test_runs_cached_under_the_old_row_and_integrator_names_are_reused(tiny_box, tmp_path, monkeypatch):
    jobs = jobs_of(tiny_box, tmp_path)
    assert [j.row for j in jobs] == ["native-leapfrog", "native-viscel"]
    assert all('integrator.kind="leapfrog"' in j.sets for j in jobs)
    olds = []
    for job in jobs:
        assert run_job(job)["returncode"] == 0
        olds.append(cached_as_before(job, tmp_path))
    assert olds[0].path.name.startswith("tinybox_native-verlet_3Hz_s1_")
    assert olds[1].path.name.startswith("tinybox_native-viscel_3Hz_s1_") and olds[1].path != jobs[1].path
    assert not any(j.path.exists() for j in jobs)

    def must_not_run(*args, **kwargs):
        raise AssertionError("a run cached under the old names ran again")
    monkeypatch.setattr(validate, "run_timed", must_not_run)
    log = []
    metas = [run_job(j, log.append) for j in jobs]
    assert all(m["cached"] for m in metas), metas
    assert [m["same_as"] for m in metas] == [o.path.name for o in olds]
    assert all(j.path.exists() for j in jobs) and all(o.path.exists() for o in olds)
    assert sum("reused" in x for x in log) == 2, log
    assert run_job(jobs[0])["cached"]  # and from now on under its own name


def test_an_old_name_matches_only_the_run_it_named(tiny_box, tmp_path):
    (job, _) = jobs_of(tiny_box, tmp_path)
    run_job(job)
    old = cached_as_before(job, tmp_path)
    assert same_run_elsewhere(job, resolved_scene(job)) == old.path
    # the same row at another step, or with Gear: not that run
    for x in ("integrator.dt=1e-4", 'integrator.kind="gear"'):
        other = validate._job(job.case, job.row, job.variant, job.seed, job.engine, [*job.sets, x], tmp_path)
        assert same_run_elsewhere(other, resolved_scene(other)) is None, x
    now = resolved_scene(job)
    stored = json.loads(old.path.with_suffix(".json").read_text())["resolved_scene"]
    assert stored["integrator"]["kind"] == "verlet" and same_resolution(stored, now)
    assert stored["integrator"]["kind"] == "verlet"  # the stored resolution is left as it was
    assert not same_resolution(dict(stored, integrator=dict(stored["integrator"], kind="gear")), now)


def test_old_row_names_cover_planted_errors_and_false_alarm_groups():
    assert old_row_names("native-leapfrog") == ["native-verlet"]
    assert old_row_names("native-leapfrog+coulomb_half") == ["native-verlet+coulomb_half"]
    assert old_row_names("native-leapfrog@r3.1") == ["native-verlet@r3.1"]
    assert old_row_names("native-viscel") == [] and old_row_names("native-viscel+inertia") == []


def test_a_run_is_limited_in_cpu_time_and_leaves_no_process_behind(tmp_path, monkeypatch):
    """compare.validate.run_timed: the limit is CPU time (a slow machine does
    not cut a run short, a run that computes too long is stopped), and every
    process the run started goes when it ends, so an engine started by a
    driver cannot outlive it."""
    monkeypatch.setattr(validate, "yield_like_this_process", lambda pid: None)
    import os
    import time
    from compare.validate import run_timed

    spin = [sys.executable, "-c", "while True: pass"]
    t0 = time.monotonic()
    rc, err, cpu = run_timed(spin, 1.0)
    assert rc == -1 and "CPU seconds" in err, err
    assert 0.9 <= cpu and time.monotonic() - t0 < 8.0

    # Sleeping costs no CPU: within the limit, the wall-clock guard (10 x) stops a hang.
    rc, err, cpu = run_timed(["sleep", "30"], 0.2)
    assert rc == -1 and "hung" in err, err

    # A child left running by the driver goes with it.
    pidfile = tmp_path / "child.pid"
    rc, err, cpu = run_timed(["sh", "-c", f"sleep 60 & echo $! > {pidfile}"], 60.0)
    assert rc == 0, err
    pid = int(pidfile.read_text())
    time.sleep(0.2)
    try:
        os.kill(pid, 0)
        alive = open(f"/proc/{pid}/stat").read().split()[2] != "Z"
    except ProcessLookupError:
        alive = False
    assert not alive, "the driver's child outlived the run"


AUTOGROUPS = "/proc/sys/kernel/sched_autogroup_enabled"


@pytest.mark.skipif(not os.path.exists(AUTOGROUPS) or open(AUTOGROUPS).read().strip() != "1",
                    reason="the kernel does not group processes by setsid here")
def test_a_run_in_a_group_of_its_own_keeps_the_drivers_niceness():
    # A child 7 nicer than the test starts a run as run_timed does (start_new_session) and
    # hands its niceness to the run's scheduler group; without that the group
    # would be at 0, and a niced suite would not yield the cores.
    code = ("import os, subprocess, sys\n"
            "from compare.validate import yield_like_this_process\n"
            "mine = os.nice(7)\n"
            "p = subprocess.Popen(['sleep', '5'], start_new_session=True)\n"
            "before = open(f'/proc/{p.pid}/autogroup').read().split()[-1]\n"
            "yield_like_this_process(p.pid)\n"
            "after = open(f'/proc/{p.pid}/autogroup').read().split()[-1]\n"
            "p.kill(); print(before, after, mine)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=validate.ROOT, check=True)
    before, after, mine = out.stdout.split()
    assert before == "0" and after == mine != "0", out


def test_a_run_kept_as_its_observables_counts_until_the_analysis_changes(tiny_suite, tmp_path, monkeypatch):
    """A finished run's metadata keeps its observables with the analysis that
    computed them, so a suite restored from the metadata alone (the outputs
    gone) reaches the same rows without running again; a changed analysis
    runs it again."""
    (job,) = jobs_of(tiny_suite, tmp_path)
    first = run_job(job)
    assert not first["cached"]
    kept = json.loads(job.path.with_suffix(".json").read_text())["observables"]
    assert kept["analysis"] == validate.analysis_hash()
    fresh, steps, n = validate.observables_of(job)
    from_file = {}
    validate._rows_of_case(from_file, job, first)
    job.path.unlink()
    log = []
    again = run_job(job, log.append)
    assert again["cached"] and not job.path.exists(), log
    restored = {}
    validate._rows_of_case(restored, job, again)
    (run_file,) = from_file["tiny"]["variants"][""]["native-paper"]["runs"]
    (run_kept,) = restored["tiny"]["variants"][""]["native-paper"]["runs"]
    assert run_kept["ok"] and run_kept["path"] is None
    for k in ("slope_deg", "bands_final", "formation_rotations", "formed", "steps", "particles"):
        assert run_kept[k] == pytest.approx(run_file[k], nan_ok=True), k
    assert run_kept["steps"] == steps > 0 and run_kept["particles"] == n
    assert run_kept["slope_deg"] == pytest.approx(fresh["slope_deg"], nan_ok=True)
    # another analysis: the kept observables no longer count, the run is made again
    monkeypatch.setattr(validate, "analysis_hash", lambda: "another")
    rerun = run_job(job, log.append)
    assert not rerun["cached"] and job.path.exists()
