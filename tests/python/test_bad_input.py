"""Bad input is refused before anything is written: every scene in
tests/bad_scenes/ gives exit status 2 and one line naming the file, the key
(with its line in the file, when the key is there) and the reason; an existing
output file is never replaced without --force. The LAMMPS and YADE drivers
refuse what they cannot represent in the same words (tests/bad_scenes/lammps/,
tests/bad_scenes/yade/). docs/errors.md describes the messages.

Each catalogue file starts with `# expect: KEY | FRAGMENT`: the key the message
must name (`-` for a file that is not TOML; its faulty line carries `# <- here`)
and a fragment of the reason."""
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
CATALOGUE = ROOT / "tests" / "bad_scenes"
NATIVE = sorted(CATALOGUE.glob("*.toml"))
LAMMPS = sorted((CATALOGUE / "lammps").glob("*.toml"))
YADE = sorted((CATALOGUE / "yade").glob("*.toml"))
BOX = ROOT / "scenes" / "box" / "f3.0_big.toml"

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def granular(*args, cwd=ROOT):
    return subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True, timeout=600, cwd=cwd)


def expectation(path):
    # KEY may carry " (--set)": the value came from an override the driver passes
    m = re.match(r"# expect: (\S+(?: \(--set\))?) \| (.+)$", path.read_text().splitlines()[0])
    assert m, f"{path}: the first line must be '# expect: KEY | FRAGMENT'"
    return m.group(1), m.group(2).strip()


def line_of(path, key):
    """The key's line, read independently of the engine: table headers and
    `name = value` lines; a syntax error's line is marked `# <- here`."""
    table = ""
    for number, raw in enumerate(path.read_text().splitlines(), 1):
        if key == "-":
            if "# <- here" in raw:
                return number
            continue
        text = raw.split("#", 1)[0].strip()
        if text.startswith("["):
            table = text.strip("[] ")
        elif "=" in text:
            name = text.split("=", 1)[0].strip()
            if (f"{table}.{name}" if table else name) == key:
                return number
    return 0


def check_message(stderr, scene, key, fragment, prefix):
    """One line: PREFIX FILE:LINE: KEY: REASON (FILE: KEY: ... when the key is not in the file)."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, f"expected one line of error, got:\n{stderr}"
    msg = lines[0]
    line = line_of(ROOT / scene, key)
    head = f"{prefix}{scene}:{line}: " if line else f"{prefix}{scene}: "
    assert msg.startswith(head), f"{msg!r} does not start with {head!r}"
    rest = msg[len(head):]
    if key == "-":
        assert line, f"{scene}: mark the faulty line with '# <- here'"
    else:
        assert rest.startswith(f"{key}: "), f"{msg!r} does not name {key} after the file"
    assert fragment in rest, f"{msg!r} lacks {fragment!r}"
    return msg


def test_catalogue_has_every_kind_of_fault():
    assert len(NATIVE) >= 30
    assert {p.name.split("_")[0] for p in NATIVE} == {"drum", "box", "particles"}
    assert LAMMPS and YADE
    for path in NATIVE + LAMMPS + YADE:
        expectation(path)


@pytest.mark.parametrize("command", ["run", "init"])
@pytest.mark.parametrize("scene", NATIVE, ids=lambda p: p.stem)
def test_bad_scene_is_refused_with_one_message_and_no_output(scene, command, tmp_path):
    key, fragment = expectation(scene)
    rel = scene.relative_to(ROOT)
    r = granular(command, rel, "-o", tmp_path / "out.h5")
    assert r.returncode == 2, r.stderr
    check_message(r.stderr, rel, key, fragment, "error: ")
    assert r.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_info_refuses_the_same_way(tmp_path):
    scene = (CATALOGUE / "drum_unknown_key_skn.toml").relative_to(ROOT)
    r = granular("info", scene, "--json")
    assert r.returncode == 2
    check_message(r.stderr, scene, "neighbor.skn", "did you mean neighbor.skin?", "error: ")


def test_set_override_is_named_as_such_without_a_line():
    r = granular("info", "scenes/drum/A.toml", "--set", "neighbor.skn=0.4")
    assert r.returncode == 2
    assert r.stderr.strip() == ("error: scenes/drum/A.toml: neighbor.skn (--set): unknown key; "
                                "did you mean neighbor.skin?")
    r = granular("info", "scenes/drum/A.toml", "--set", "drum.diameter=-3")
    assert r.returncode == 2
    assert r.stderr.strip() == "error: scenes/drum/A.toml: drum.diameter (--set): must be > 0, got -3"


def test_a_value_overridden_by_set_is_judged_not_the_file_one():
    scene = (CATALOGUE / "drum_negative_dt.toml").relative_to(ROOT)
    r = granular("info", scene, "--set", "integrator.dt=0.005")
    assert r.returncode == 0, r.stderr


def test_driver_catalogue_scenes_are_valid_native_scenes():
    """The drivers' entries are refused by the driver, not by the scene reader."""
    for scene in LAMMPS + YADE:
        r = granular("info", scene)
        assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("command", ["run", "init"])
def test_existing_output_is_byte_identical_after_a_refused_run(command, tmp_path):
    out = tmp_path / "earlier.h5"
    earlier = os.urandom(4096)
    out.write_bytes(earlier)
    # a bad scene
    r = granular(command, (CATALOGUE / "drum_fill_cannot_be_packed.toml").relative_to(ROOT), "-o", out)
    assert r.returncode == 2
    assert out.read_bytes() == earlier
    # a good scene, without --force
    r = granular(command, BOX, "-o", out, "--set", "run.settle=0.001", "--set", "run.duration=0")
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1
    assert str(out) in r.stderr and "pass --force" in r.stderr
    assert out.read_bytes() == earlier
    # a bad scene with --force: still refused before the file is touched
    r = granular(command, (CATALOGUE / "box_zero_dt.toml").relative_to(ROOT), "-o", out, "--force")
    assert r.returncode == 2
    assert out.read_bytes() == earlier
    assert sorted(p.name for p in tmp_path.iterdir()) == ["earlier.h5"]


@pytest.mark.parametrize("command", ["run", "init"])
def test_force_overwrites(command, tmp_path):
    import h5py
    out = tmp_path / "earlier.h5"
    out.write_bytes(b"results of an earlier run")
    r = granular(command, BOX, "-o", out, "--force", "--set", "run.settle=0.001", "--set", "run.duration=0",
                 *(["-q", "--threads", "1"] if command == "run" else []))
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as h5:
        assert h5.attrs["scene_name"] == "f3.0_big"
        assert h5["frames/time"].shape[0] >= 1


def test_default_output_name_is_guarded_too(tmp_path):
    """Without -o the output is NAME.h5 (run) or NAME_init.h5 (init) in the working directory."""
    for command, name in (("run", "f3.0_big.h5"), ("init", "f3.0_big_init.h5")):
        (tmp_path / name).write_bytes(b"keep")
        r = granular(command, BOX, "--set", "run.settle=0.001", "--set", "run.duration=0", cwd=tmp_path)
        assert r.returncode == 2 and name in r.stderr and "--force" in r.stderr
        assert (tmp_path / name).read_bytes() == b"keep"


def test_missing_output_directory_is_refused_before_running(tmp_path):
    r = granular("run", BOX, "-o", tmp_path / "no" / "such" / "dir.h5")
    assert r.returncode == 2 and "does not exist" in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_bad_command_line_exits_2():
    assert granular("run").returncode == 2
    assert granular("run", BOX, "--threads", "0").returncode == 2
    assert granular("--version").returncode == 0


# --- the LAMMPS and YADE drivers


def driver(module, scene, out, *extra):
    env = dict(os.environ, GRANULAR_BIN=str(BIN), PYTHONPATH=str(ROOT))
    return subprocess.run(["/usr/bin/python3", "-m", module, "run", str(scene), "-o", str(out), "-q", *extra],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)


def has_lammps():
    return subprocess.run(["/usr/bin/python3", "-c", "import lammps"], capture_output=True).returncode == 0


needs_lammps = pytest.mark.skipif(not has_lammps(), reason="LAMMPS Python module missing")
needs_yade = pytest.mark.skipif(shutil.which("yade") is None, reason="yade not on PATH")


def check_driver_refusal(module, scene, tmp_path, *extra):
    key, fragment = expectation(scene)
    rel = scene.relative_to(ROOT)
    out = tmp_path / "out.h5"
    r = driver(module, rel, out, *extra)
    assert r.returncode == 2, r.stderr
    check_message(r.stderr, rel, key, fragment, f"{module}: error: ")
    assert list(tmp_path.iterdir()) == []  # no output, no YADE work directory


@needs_lammps
@pytest.mark.parametrize("scene", LAMMPS, ids=lambda p: p.stem)
def test_lammps_refuses_what_it_cannot_represent(scene, tmp_path):
    check_driver_refusal("lammps_cases", scene, tmp_path)


@needs_yade
@pytest.mark.parametrize("scene", YADE, ids=lambda p: p.stem)
def test_yade_refuses_what_it_cannot_represent(scene, tmp_path):
    check_driver_refusal("yade_cases", scene, tmp_path)


@pytest.mark.parametrize("module", [pytest.param("lammps_cases", marks=needs_lammps),
                                    pytest.param("yade_cases", marks=needs_yade)])
@pytest.mark.parametrize("name", ["drum_misspelt_required_key", "box_big_disk_larger_than_box", "drum_syntax_error",
                                  "particles_wrong_side"])
def test_drivers_pass_on_the_native_message(module, name, tmp_path):
    """A scene the engine refuses: the driver's one line is the engine's message."""
    check_driver_refusal(module, CATALOGUE / f"{name}.toml", tmp_path)


@needs_lammps
def test_lammps_refusal_of_a_set_override_says_so(tmp_path):
    r = driver("lammps_cases", "scenes/box/f3.0_big.toml", tmp_path / "out.h5", "--set", "contact.law=viscel")
    assert r.returncode == 2
    assert r.stderr.strip().startswith("lammps_cases: error: scenes/box/f3.0_big.toml: contact.law (--set): ")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("module", [pytest.param("lammps_cases", marks=needs_lammps),
                                    pytest.param("yade_cases", marks=needs_yade)])
def test_drivers_keep_an_existing_output(module, tmp_path):
    out = tmp_path / "earlier.h5"
    out.write_bytes(b"keep")
    r = driver(module, BOX.relative_to(ROOT), out)
    assert r.returncode == 2 and str(out) in r.stderr and "--force" in r.stderr
    assert out.read_bytes() == b"keep"


# --- the box's integrator names


def test_the_box_integrator_is_leapfrog_or_gear_and_verlet_is_refused():
    """The box's integrator.kind takes "leapfrog" (the default, the drum's name
    for the same integrator) and "gear"; "verlet" is refused with the names
    allowed, by the engine and in the same words by the YADE driver's check."""
    import json
    from types import SimpleNamespace

    from lammps_cases.scene import SceneRefused
    from yade_cases.__main__ import refuse_unrepresentable

    def box(scene):
        return SimpleNamespace(kind="shaken_box", scene=scene, derived=scene.get("derived", {}))

    rel = BOX.relative_to(ROOT)
    assert json.loads(granular("info", rel, "--json").stdout)["integrator"]["kind"] == "leapfrog"
    for kind in ("leapfrog", "gear"):
        r = granular("info", rel, "--json", "--set", f"integrator.kind={kind}")
        assert r.returncode == 0, r.stderr
        scene = json.loads(r.stdout)
        assert scene["integrator"]["kind"] == kind
        refuse_unrepresentable(box(scene))
    r = granular("info", rel, "--set", "integrator.kind=verlet")
    assert r.returncode == 2
    head = f"error: {rel}: integrator.kind (--set): "
    assert r.stderr.strip().startswith(head), r.stderr
    reason = r.stderr.strip()[len(head):]
    assert reason.startswith('unknown value "verlet"') and '"leapfrog", "gear"' in reason, reason
    scene["integrator"]["kind"] = "verlet"
    with pytest.raises(SceneRefused) as refused:
        refuse_unrepresentable(box(scene))
    assert refused.value.key == "integrator.kind" and refused.value.reason == reason


@needs_yade
def test_the_yade_driver_refuses_verlet_as_the_engine_does(tmp_path):
    rel = BOX.relative_to(ROOT)
    native = granular("info", rel, "--set", "integrator.kind=verlet")
    r = driver("yade_cases", rel, tmp_path / "out.h5", "--set", "integrator.kind=verlet")
    assert r.returncode == 2
    assert r.stderr.strip() == "yade_cases: error: " + native.stderr.strip().removeprefix("error: ")
    assert list(tmp_path.iterdir()) == []


def test_info_lists_the_registered_laws_and_the_scene_accepts_exactly_those():
    """`granular info --json` lists the contact laws each scene kind can use
    (native/src/contact/laws.hpp), and the scene's contact.law key accepts
    those and refuses any other."""
    for scene, expect in (("scenes/drum/A.toml", {("rapaport", "normal"), ("linear", "normal"), ("viscel", "normal")}),
                          ("scenes/box/f3.0_big.toml", {("poeschel_herrmann", "normal"),
                                                        ("poeschel_herrmann", "literal"), ("viscel", "normal")})):
        r = granular("info", scene, "--json")
        assert r.returncode == 0, r.stderr
        laws = json.loads(r.stdout)["derived"]["contact_laws"]
        assert {(x["contact.law"], x["contact.damping"]) for x in laws} == expect
        for law in {name for name, _ in expect}:
            ok = granular("info", scene, "--set", f'contact.law="{law}"')
            assert ok.returncode == 0, ok.stderr
        bad = granular("info", scene, "--set", 'contact.law="hertz"')
        assert bad.returncode == 2
        assert "contact.law" in bad.stderr and "hertz" in bad.stderr
