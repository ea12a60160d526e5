"""Axial segregation space-time diagram of the rotating drum (Rapaport 2002, Fig. 1).

The engine writes its own fine-grained profile in /profile; when that is absent
(or empty) the same quantity is recomputed from the snapshots, so runs from
engines that do not write /profile can still be compared.
"""

from __future__ import annotations

import numpy as np

SMALL = 0  # species code of the small particles in the drum scenes


def axial_profile(y, diameter, species, edges):
    """Volume-weighted fraction of small particles (species 0) in each slice.

    Weights are d**3 (particle volume up to a constant) because Rapaport's
    segregation plots measure volume, not number: one big particle of
    d = 1.3 counts 2.197 times as much as a small one of d = 1.

    y, diameter, species: (N,) arrays for one snapshot; edges: (S+1,) increasing
    slice edges.  Particles outside [edges[0], edges[-1]] are ignored (the last
    slice includes its upper edge).  Returns (S,) float64, NaN in empty slices.
    """
    y = np.asarray(y, dtype=np.float64)
    w = np.asarray(diameter, dtype=np.float64) ** 3
    small = np.asarray(species) == SMALL
    edges = np.asarray(edges, dtype=np.float64)
    total, _ = np.histogram(y, bins=edges, weights=w)
    small_vol, _ = np.histogram(y[small], bins=edges, weights=w[small])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, small_vol / total, np.nan)


def _centres_to_edges(c):
    """Cell edges for (possibly irregular) sample times, for pcolormesh."""
    c = np.asarray(c, dtype=np.float64)
    if c.size == 0:
        return np.zeros(0)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])


class SpaceTime:
    """Small-particle volume fraction as a function of time and axial position y.

    Follows the freud pattern: configure in the constructor, ``compute(run)``
    returns self, results are read-only properties that raise RuntimeError
    until ``compute`` has been called.

    slice_width: width of the axial slices when the profile is recomputed from
    frames (default 1.0, i.e. one small-particle diameter).  The number of
    slices is round(L / slice_width), so the actual width is adjusted slightly
    to span exactly -L/2..L/2.  Ignored when the engine's /profile is used.
    """

    def __init__(self, slice_width=None):
        self.slice_width = 1.0 if slice_width is None else float(slice_width)
        if self.slice_width <= 0:
            raise ValueError(f"slice_width must be positive, got {slice_width}")
        self._result = None

    def compute(self, run):
        if run.rotation_period is None:
            raise ValueError(f"{run.path}: space-time plot needs a drum run "
                             f"(scene_kind={run.attrs.get('scene_kind')!r})")
        prof = run.profile
        if prof is not None and prof.time.size > 0:
            source, time, edges, frac = "profile", prof.time, prof.edges, prof.small_fraction
        else:
            source = "frames"
            time, edges, frac = run.frames.time, self._frame_edges(run), None
            y = run.frames.position[..., 1]
            drum = run.scene.get("drum", {})
            if drum.get("ends") == "periodic":
                # an engine may store unwrapped coordinates; wrap into the cell
                length = float(drum["length"])
                outside = (y < -length / 2) | (y >= length / 2)
                y = np.where(outside, (y + length / 2) % length - length / 2, y)
            frac = np.array([axial_profile(y[f], run.frames.diameter[f],
                                           run.frames.species[f], edges)
                             for f in range(run.frames.n_frames)]).reshape(-1, edges.size - 1)
        self._result = {
            "source": source,
            "time_rotations": np.asarray(time, dtype=np.float64) / run.rotation_period,
            "y_edges": np.asarray(edges, dtype=np.float64),
            "small_fraction": np.asarray(frac, dtype=np.float64),
        }
        return self

    def _frame_edges(self, run):
        try:
            length = float(run.scene["drum"]["length"])
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{run.path}: scene_json has no drum.length; "
                             "cannot slice the frames") from None
        n = max(1, int(round(length / self.slice_width)))
        return np.linspace(-length / 2, length / 2, n + 1)

    def _get(self, key):
        if self._result is None:
            raise RuntimeError("SpaceTime: call compute(run) before reading results")
        return self._result[key]

    @property
    def source(self):
        """"profile" if the engine's /profile was used, "frames" if recomputed."""
        return self._get("source")

    @property
    def time_rotations(self):
        """(P,) sample times in drum rotations."""
        return self._get("time_rotations")

    @property
    def y_edges(self):
        """(S+1,) slice edges along the drum axis y."""
        return self._get("y_edges")

    @property
    def y_centres(self):
        """(S,) slice centres along the drum axis y."""
        e = self._get("y_edges")
        return 0.5 * (e[1:] + e[:-1])

    @property
    def small_fraction(self):
        """(P, S) volume-weighted small fraction; NaN where a slice is empty."""
        return self._get("small_fraction")

    def plot(self, ax=None):
        """Draw the diagram like Rapaport 2002 Fig. 1: rotations left to right,
        axial position vertical, dark = small (gray_r, 0..1).  Empty slices
        (NaN) are pale blue, because any gray would read as a mixed slice."""
        import matplotlib
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(10, 4))
        cmap = matplotlib.colormaps["gray_r"].copy()
        cmap.set_bad("lightsteelblue")
        norm = matplotlib.colors.Normalize(vmin=0.0, vmax=1.0)
        t = self.time_rotations
        if t.size:
            mesh = ax.pcolormesh(_centres_to_edges(t), self.y_edges,
                                 np.ma.masked_invalid(self.small_fraction.T),
                                 cmap=cmap, norm=norm, shading="flat", rasterized=True)
        else:  # zero samples: still produce a labelled, empty plot
            mesh = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
            ax.text(0.5, 0.5, "no samples", transform=ax.transAxes,
                    ha="center", va="center")
        ax.set_ylim(self.y_edges[0], self.y_edges[-1])
        ax.set_xlabel("rotations")
        ax.set_ylabel("axial position y")
        ax.figure.colorbar(mesh, ax=ax, label="small-particle volume fraction")
        return ax
