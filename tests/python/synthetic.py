"""Synthetic drum runs in the granular-frames schema, for analysis tests."""
import json
import math

import h5py
import numpy as np


def write_drum_run(path, positions, species, diameter, times=None, ends="periodic", length=128.0, diameter_drum=16.0,
                   omega=0.5, profile=None):
    """positions (F, N, 3); species, diameter (N,) or (F, N); times in simulation
    time units (default: one frame per rotation)."""
    positions = np.asarray(positions, dtype=np.float64)
    F, N, _ = positions.shape
    period = 2 * math.pi / omega
    times = np.arange(F) * period if times is None else np.asarray(times, dtype=np.float64)
    scene = {"scene": {"kind": "drum", "name": "synthetic"},
             "drum": {"length": length, "diameter": diameter_drum, "ends": ends, "omega": omega},
             "run": {"rotations": float(times[-1] / period) if F else 0.0}}
    with h5py.File(path, "w") as h5:
        for k, v in {"schema": "granular-frames", "schema_version": 1, "engine": "synthetic", "engine_version": "0",
                     "scene_kind": "drum", "scene_name": "synthetic", "dim": 3, "scene_json": json.dumps(scene),
                     "omega": omega, "rotation_period": period}.items():
            h5.attrs[k] = v
        g = h5.create_group("frames")
        g.attrs["species_names"] = ["small", "big"]
        g["time"] = times
        g["step"] = np.arange(F, dtype=np.int64)
        g["id"] = np.broadcast_to(np.arange(N, dtype=np.int64), (F, N))
        g["species"] = np.broadcast_to(species, (F, N)).astype(np.int32)
        g["diameter"] = np.broadcast_to(diameter, (F, N)).astype(np.float64)
        g["position"] = positions
        g["velocity"] = np.zeros_like(positions)
        g["angular_velocity"] = np.zeros_like(positions)
        if profile is not None:
            p = h5.create_group("profile")
            for k, v in zip(("time", "edges", "small_fraction"), profile):
                p[k] = np.asarray(v, dtype=np.float64)
    return path


def random_bed(rng, n, length=128.0, diameter_drum=16.0, y=None):
    """n points uniformly in the lower half of the drum's cross-section."""
    r = (diameter_drum / 2 - 0.6) * np.sqrt(rng.random(n))
    phi = -math.pi * rng.random(n)  # lower half: z < 0
    y = rng.uniform(-length / 2, length / 2, n) if y is None else y
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)


def species_and_diameters(rng, n):
    """Equal numbers of each species in random order; Rapaport's diameters."""
    species = rng.permutation(np.arange(n) % 2).astype(np.int32)
    d = np.where(species == 1, 1.3, 1.0) - 0.2 * rng.random(n)
    return species, d


def banded_y(rng, species, k, length=128.0):
    """Axial positions with k equal bands, alternately small and big
    (band 0 small), each particle uniform within its species' bands."""
    w = length / k
    small_bands = np.arange(0, k, 2)
    big_bands = np.arange(1, k, 2)
    bands = np.where(species == 0, rng.choice(small_bands, len(species)), rng.choice(big_bands, len(species)))
    return -length / 2 + (bands + rng.random(len(species))) * w
