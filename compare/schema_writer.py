"""Writer for the "granular-frames" HDF5 schema (docs/output_schema.md), used by
the reference-engine drivers (lammps_cases/, yade_cases/) so that their output
goes through the same analysis as the native engine's. Datasets grow by one row
per append and the file is flushed after each, like the native writer: a run
that stops early keeps everything written so far."""

from __future__ import annotations

import h5py
import numpy as np

from .reader import SCHEMA, SCHEMA_VERSION


class SchemaWriter:
    def __init__(self, path, dim: int, n_particles: int, attrs: dict, species_names, with_force=False):
        self.h5 = h5py.File(path, "w")
        self.dim, self.n = dim, n_particles
        self.h5.attrs["schema"] = SCHEMA
        self.h5.attrs["schema_version"] = SCHEMA_VERSION
        self.h5.attrs["dim"] = dim
        for k, v in attrs.items():
            self.h5.attrs[k] = v
        g = self.h5.create_group("frames")
        g.attrs["species_names"] = list(species_names)
        ang = 3 if dim == 3 else 1
        shapes = {"time": ((), "f8"), "step": ((), "i8"), "id": ((n_particles,), "i8"),
                  "species": ((n_particles,), "i4"), "diameter": ((n_particles,), "f8"),
                  "position": ((n_particles, dim), "f8"), "velocity": ((n_particles, dim), "f8"),
                  "angular_velocity": ((n_particles, ang), "f8")}
        if with_force:
            shapes["force"] = ((n_particles, dim), "f8")
        self.frames = {k: self._make(g, k, s, t) for k, (s, t) in shapes.items()}
        self.series_group = None

    @staticmethod
    def _make(group, name, row, dtype):
        return group.create_dataset(name, shape=(0,) + row, maxshape=(None,) + row, dtype=dtype,
                                    chunks=(1,) + row if row else (1024,))

    @staticmethod
    def _append(ds, value):
        ds.resize(ds.shape[0] + 1, axis=0)
        ds[-1] = value

    def frame(self, time, step, ids, species, diameter, position, velocity, angular_velocity, force=None):
        """One snapshot; rows are sorted by id here."""
        order = np.argsort(ids, kind="stable")
        w = np.asarray(angular_velocity, dtype=float)
        if self.dim == 2 and w.ndim == 2 and w.shape[1] == 3:
            w = w[:, 2:3]  # 2D: only the z component is stored
        rows = {"time": time, "step": step, "id": np.asarray(ids)[order], "species": np.asarray(species)[order],
                "diameter": np.asarray(diameter)[order], "position": np.asarray(position)[order, :self.dim],
                "velocity": np.asarray(velocity)[order, :self.dim], "angular_velocity": w[order]}
        if "force" in self.frames:
            rows["force"] = np.asarray(force)[order, :self.dim]
        for k, v in rows.items():
            self._append(self.frames[k], v)
        self.h5.flush()

    def init_profile(self, edges):
        g = self.h5.create_group("profile")
        g.attrs["axis"] = "y"
        g.attrs["weighting"] = "volume"
        g["edges"] = np.asarray(edges, dtype=float)
        self.profile_time = self._make(g, "time", (), "f8")
        self.profile_values = self._make(g, "small_fraction", (len(edges) - 1,), "f8")

    def profile(self, time, small_fraction):
        self._append(self.profile_time, time)
        self._append(self.profile_values, small_fraction)
        self.h5.flush()

    def init_series(self, group, columns: dict):
        """columns: name -> row width (0 for a scalar per sample)."""
        g = self.h5.create_group(group)
        self.series_cols = {k: self._make(g, k, (w,) if w else (), "f8") for k, w in columns.items()}

    def series(self, **values):
        for k, v in values.items():
            self._append(self.series_cols[k], v)

    def close(self):
        self.h5.flush()
        self.h5.close()


def axial_small_fraction(y, diameter, species, edges):
    """Volume-weighted (d^3) small fraction per axial slice, as the native
    engine computes it (engine/drum.cpp); NaN for an empty slice."""
    ns = len(edges) - 1
    k = np.clip(np.searchsorted(edges, y, side="right") - 1, 0, ns - 1)
    vol = np.asarray(diameter) ** 3
    allv = np.bincount(k, weights=vol, minlength=ns)
    small = np.bincount(k, weights=vol * (np.asarray(species) == 0), minlength=ns)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(allv > 0, small / np.where(allv > 0, allv, 1), np.nan)
