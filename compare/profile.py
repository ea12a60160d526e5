"""The axial concentration profile c(y, t) from snapshots, cross-checked
against the engine's own per-sample profile where the run has one."""
import numpy as np

from ._common import Result
from .spacetime import axial_profile


def wrapped_y(run, frame):
    """Axial coordinates of one frame, wrapped into [-L/2, L/2) for periodic ends."""
    y = run.frames.position[frame, :, 1]
    drum = run.scene.get("drum", {})
    if drum.get("ends") == "periodic":
        # Only coordinates outside the cell are wrapped: rewrapping the others
        # would move a particle sitting exactly on a slice edge by rounding.
        length = float(drum["length"])
        outside = (y < -length / 2) | (y >= length / 2)
        if outside.any():
            y = np.where(outside, (y + length / 2) % length - length / 2, y)
    return y


def drum_length(run):
    try:
        return float(run.scene["drum"]["length"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{run.path}: not a drum run (no drum.length in the scene)") from None


class AxialProfile(Result):
    """Volume-weighted small fraction in axial slices, from the snapshots.

    ``compute(run)`` slices every frame (slice edges: the engine's /profile
    edges if present, else ``slice_width`` slices over -L/2..L/2) and, where the
    engine wrote a profile sample at a frame's time, records the largest
    absolute difference between the two (``engine_max_difference``; NaN-aware,
    None when there is nothing to compare).
    """

    def __init__(self, slice_width=1.0):
        self.slice_width = float(slice_width)

    def compute(self, run):
        length = drum_length(run)
        prof = run.profile
        if prof is not None and prof.edges.size > 1:
            edges = prof.edges
        else:
            edges = np.linspace(-length / 2, length / 2, max(1, round(length / self.slice_width)) + 1)
        frac = np.array([axial_profile(wrapped_y(run, f), run.frames.diameter[f], run.frames.species[f], edges)
                         for f in range(run.frames.n_frames)]).reshape(-1, edges.size - 1)
        worst, compared = None, 0
        if prof is not None and prof.time.size and run.frames.n_frames:
            for f, t in enumerate(run.frames.time):
                row = int(np.argmin(np.abs(prof.time - t)))
                if abs(prof.time[row] - t) > 1e-9 * max(1.0, abs(t)):
                    continue
                a, b = prof.small_fraction[row], frac[f]
                if not np.array_equal(np.isnan(a), np.isnan(b)):
                    worst = np.inf
                else:
                    ok = ~np.isnan(a)
                    d = float(np.max(np.abs(a[ok] - b[ok]))) if ok.any() else 0.0
                    worst = d if worst is None else max(worst, d)
                compared += 1
        self._result = {"time_rotations": run.frames.time / run.rotation_period, "edges": edges,
                   "small_fraction": frac, "engine_max_difference": worst, "frames_compared": compared}
        return self

    time_rotations = property(lambda self: self._get("time_rotations"))
    edges = property(lambda self: self._get("edges"))
    small_fraction = property(lambda self: self._get("small_fraction"))
    engine_max_difference = property(lambda self: self._get("engine_max_difference"))
    frames_compared = property(lambda self: self._get("frames_compared"))

    def plot(self, ax=None):
        import matplotlib.pyplot as plt
        ax = ax or plt.gca()
        e = self.edges
        yc = 0.5 * (e[1:] + e[:-1])
        for t, row in zip(self.time_rotations, self.small_fraction):
            ax.plot(yc, row, lw=0.8, label=f"{t:.0f} rot")
        ax.set_xlabel("axial position y")
        ax.set_ylabel("small-particle volume fraction")
        if len(self.time_rotations) <= 8:
            ax.legend(fontsize="small")
        return ax
