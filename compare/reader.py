"""Reader for the "granular-frames" HDF5 schema (docs/output_schema.md).

All analysis code reads runs through :func:`read_run` so that schema checks and
the particle re-ordering happen in exactly one place.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import h5py
import numpy as np

SCHEMA = "granular-frames"
SCHEMA_VERSION = 1

FRAME_DATASETS = ("time", "step", "id", "species", "diameter",
                  "position", "velocity", "angular_velocity")
PER_PARTICLE = ("id", "species", "diameter", "position", "velocity",
                "angular_velocity")
PROFILE_DATASETS = ("time", "edges", "small_fraction")


@dataclass
class Frames:
    """Snapshots, columns matched by particle id (column j is the same particle in every frame).

    ``time``, ``diameter``, ``position``, ``velocity`` and ``angular_velocity`` are
    float64; ``step``, ``id`` (int64) and ``species`` (int32) keep integer dtypes
    because they are labels that are compared for equality.
    """

    time: np.ndarray              # (F,)
    step: np.ndarray              # (F,)
    id: np.ndarray                # (F, N)
    species: np.ndarray           # (F, N)
    diameter: np.ndarray          # (F, N)
    position: np.ndarray          # (F, N, dim)
    velocity: np.ndarray          # (F, N, dim)
    angular_velocity: np.ndarray  # (F, N, 3) in 3D, (F, N, 1) in 2D
    species_names: tuple = ()

    @property
    def n_frames(self) -> int:
        return self.time.shape[0]

    @property
    def n_particles(self) -> int:
        return self.id.shape[1] if self.id.ndim == 2 else 0


@dataclass
class Profile:
    """The engine's own axial small-particle profile along y (drum only)."""

    time: np.ndarray            # (P,)
    edges: np.ndarray           # (S+1,)
    small_fraction: np.ndarray  # (P, S), NaN in empty slices


@dataclass
class Run:
    """One engine run: root attributes, parsed scene, frames and optional profile."""

    path: Path
    attrs: dict
    scene: dict
    dim: int
    frames: Frames
    profile: Optional[Profile]
    rotation_period: Optional[float]


def _decode(value):
    """h5py returns str, bytes or numpy scalars/arrays depending on how the writer
    stored an attribute (variable- vs fixed-length strings); normalise to Python."""
    if isinstance(value, (bytes, np.bytes_)):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "SO":
            return [_decode(v) for v in value.tolist()]
        return value.tolist() if value.ndim else value.item()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _sort_by_id(arrays: dict) -> dict:
    """Re-order every per-particle array so that each frame is sorted by id.

    The schema promises sorted ids, but checking costs nothing and makes
    frame-to-frame matching (displacements, velocities) safe for any engine.
    """
    order = np.argsort(arrays["id"], axis=1, kind="stable")
    out = {}
    for name in PER_PARTICLE:
        a = arrays[name]
        idx = order if a.ndim == 2 else order[:, :, None]
        out[name] = np.take_along_axis(a, idx, axis=1)
    return out


def open_h5(path):
    """Open an output file for reading. A run still writing, or killed while
    writing, leaves the file marked as open by its (single) writer; HDF5's
    single-writer/multiple-reader mode reads it as it stands on disk."""
    try:
        return h5py.File(path, "r")
    except OSError:
        return h5py.File(path, "r", swmr=True)


def _complete_rows(group, names, path):
    """Rows every dataset in ``names`` holds: a run stopped while appending one
    sample (killed between two datasets' writes) leaves at most one dataset a
    row ahead; that partial sample is left out. A larger mismatch is an error."""
    rows = [group[n].shape[0] for n in names]
    if not rows:
        return 0
    if max(rows) - min(rows) > 1:
        raise ValueError(f"{path}: datasets in /{group.name.strip('/')} disagree on their length "
                         f"({dict(zip(names, rows))})")
    return min(rows)


def read_series(path, group):
    """The datasets of a group that grows by one row per sample (/trace,
    /coulomb, ...) as a dict of float64 arrays cut to their complete rows, or
    None if the file has no such group."""
    with open_h5(path) as h5:
        if group not in h5:
            return None
        g = h5[group]
        names = [k for k in g.keys() if isinstance(g[k], h5py.Dataset)]
        n = _complete_rows(g, names, path)
        return {k: g[k][:n].astype(np.float64) for k in names}


def read_run(path) -> Run:
    """Read a granular-frames HDF5 file.

    Raises FileNotFoundError if the file does not exist and ValueError (naming the
    file and the problem) if it is not a readable file of this schema.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        h5 = open_h5(path)
    except OSError as exc:
        raise ValueError(f"{path}: not an HDF5 file ({exc})") from None

    def fail(problem):
        raise ValueError(f"{path}: {problem}")

    with h5:
        attrs = {k: _decode(v) for k, v in h5.attrs.items()}
        if "schema" not in attrs:
            fail(f"missing root attribute 'schema' (expected {SCHEMA!r})")
        if attrs["schema"] != SCHEMA:
            fail(f"schema is {attrs['schema']!r}, expected {SCHEMA!r}")
        if attrs.get("schema_version") != SCHEMA_VERSION:
            fail(f"schema_version is {attrs.get('schema_version')!r}, "
                 f"this reader understands {SCHEMA_VERSION}")
        for key in ("dim", "scene_json"):
            if key not in attrs:
                fail(f"missing root attribute {key!r}")
        try:
            scene = json.loads(attrs["scene_json"])
        except (TypeError, ValueError) as exc:
            fail(f"scene_json is not valid JSON ({exc})")
        dim = int(attrs["dim"])

        if "frames" not in h5:
            fail("missing group /frames")
        g = h5["frames"]
        missing = [n for n in FRAME_DATASETS if n not in g]
        if missing:
            fail(f"missing dataset(s) in /frames: {', '.join(missing)}")
        n_complete = _complete_rows(g, FRAME_DATASETS + (("force",) if "force" in g else ()), path)
        raw = {n: g[n][:n_complete] for n in FRAME_DATASETS}
        species_names = tuple(_decode(g.attrs.get("species_names", np.array([]))) or ())

        n_frames = raw["time"].shape[0]
        if raw["id"].ndim != 2:
            fail(f"/frames/id has shape {raw['id'].shape}, expected (F, N)")
        for name in PER_PARTICLE:
            if raw[name].shape[:2] != raw["id"].shape or raw[name].shape[0] != n_frames:
                fail(f"/frames/{name} has shape {raw[name].shape}, "
                     f"inconsistent with /frames/id {raw['id'].shape} and time ({n_frames},)")
        if raw["position"].ndim != 3 or raw["position"].shape[2] != dim:
            fail(f"/frames/position has shape {raw['position'].shape}, expected (F, N, {dim})")

        cols = _sort_by_id(raw)
        if n_frames and np.any(cols["id"] != cols["id"][:1]):
            fail("particle ids differ between frames (the schema requires a constant set)")
        frames = Frames(
            time=raw["time"].astype(np.float64),
            step=raw["step"].astype(np.int64),
            id=cols["id"].astype(np.int64),
            species=cols["species"].astype(np.int32),
            diameter=cols["diameter"].astype(np.float64),
            position=cols["position"].astype(np.float64),
            velocity=cols["velocity"].astype(np.float64),
            angular_velocity=cols["angular_velocity"].astype(np.float64),
            species_names=species_names,
        )

        profile = None
        if "profile" in h5:
            p = h5["profile"]
            missing = [n for n in PROFILE_DATASETS if n not in p]
            if missing:
                fail(f"missing dataset(s) in /profile: {', '.join(missing)}")
            n_prof = _complete_rows(p, ("time", "small_fraction"), path)
            profile = Profile(p["time"][:n_prof].astype(np.float64), p["edges"][()].astype(np.float64),
                              p["small_fraction"][:n_prof].astype(np.float64))
            n_slices = profile.edges.shape[0] - 1
            if profile.small_fraction.shape != (profile.time.shape[0], n_slices):
                fail(f"/profile/small_fraction has shape {profile.small_fraction.shape}, "
                     f"expected ({profile.time.shape[0]}, {n_slices})")

    rotation_period = None
    if attrs.get("scene_kind") == "drum":
        if "rotation_period" in attrs:
            rotation_period = float(attrs["rotation_period"])
        else:  # older writers: derive it rather than lose the time axis
            omega = attrs.get("omega", scene.get("drum", {}).get("omega"))
            if omega:
                rotation_period = 2.0 * math.pi / float(omega)

    return Run(path=path, attrs=attrs, scene=scene, dim=dim, frames=frames,
               profile=profile, rotation_period=rotation_period)
