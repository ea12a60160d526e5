"""What the launcher and the YADE scripts share, in plain Python (no YADE):
the work directory (the native initial state as .npz, the scene as JSON); the
output schedules and the shaker are compare.schedule's, shared with lammps_cases."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

INITIAL_FIELDS = ("id", "species", "diameter", "position", "velocity", "angular_velocity", "mass", "inertia")


def write_workdir(work: Path, ini, options: dict) -> None:
    """work/initial.npz (arrays sorted by id) and work/case.json."""
    work.mkdir(parents=True, exist_ok=True)
    order = np.argsort(ini.id, kind="stable")
    np.savez(work / "initial.npz", **{k: np.asarray(getattr(ini, k))[order] for k in INITIAL_FIELDS})
    attrs = {k: ini.attrs.get(k, "") for k in ("scene_json", "scene_toml", "scene_file")}
    case = {"kind": ini.kind, "name": ini.name, "scene": ini.scene, "derived": ini.derived, "attrs": attrs,
            "options": options}
    (work / "case.json").write_text(json.dumps(case, indent=1))


def read_workdir(work):
    work = Path(work)
    case = json.loads((work / "case.json").read_text())
    with np.load(work / "initial.npz") as z:
        ini = {k: z[k] for k in INITIAL_FIELDS}
    return case, ini
