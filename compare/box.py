"""Observables of the vertically shaken box (Poeschel and Herrmann, Europhys. Lett. 1995).

Four observables in the freud style of :mod:`compare.spacetime` (configure in
the constructor, ``compute(run)`` returns self, results are properties that
raise RuntimeError before ``compute``, ``plot(ax=None)`` returns the axis,
``as_dict()`` gives JSON-safe values):

* :class:`BigDiskHeight` -- height of the big disk above the floor (Fig. 4),
  waiting time and rise time of the Brazil-nut rise;
* :class:`ConvectiveFlux` -- net flux Phi(D) through horizontal lines (Fig. 3);
* :class:`VelocityField` -- stroboscopic drift velocity field (Fig. 1);
* :class:`ForceRatio` -- mean contact force on small disks around the big disk,
  with and without the big disk.

plus :func:`onset_fraction` / :func:`onset_threshold` for the onset frequency
and :func:`observe_box` that collects everything of one run as a dict.
Definitions and the reasons for the defaults: docs/observables.md, "Shaken-box
observables".

Data read here beyond :func:`compare.reader.read_run`: ``/frames/force`` and
``/trace`` (read with h5py from ``run.path``, columns matched by particle id).
"""

from __future__ import annotations

import math

import numpy as np

from ._common import Result, clean_json  # noqa: E402
from .reader import open_h5, read_series  # noqa: E402

SMALL, BIG, WALL = 0, 1, 2  # species codes of the shaken-box scenes

__all__ = ["BigDiskHeight", "ConvectiveFlux", "VelocityField", "ForceRatio", "onset_fraction",
           "onset_threshold", "observe_box", "Shaker", "box_y", "node_frames", "settled_frame",
           "bed_height", "read_forces", "read_trace"]


# --------------------------------------------------------------------------- helpers

class Shaker:
    """The box's prescribed motion, the same closed form as the native engine
    (native/src/integrate/motion.hpp):

    y_box(t) = A s(t) sin(phi(t)),  phi(t) = 2 pi int_settle^t f(t') dt',

    f ramped linearly from ``frequency`` to ``ramp_to`` over
    [ramp_start, ramp_start + ramp_time] after the start of shaking, and the
    envelope s rising linearly from 0 to 1 over the first ``startup_cycles``
    cycles.  Parameters come from scene_json (``shaking``, ``run.settle``) with
    the root attributes as fallback.
    """

    def __init__(self, run):
        sh = dict(run.scene.get("shaking", {}) or {})
        attrs = run.attrs
        self.amplitude = float(sh.get("amplitude", attrs.get("amplitude", 0.0)))
        self.f0 = float(sh.get("frequency", attrs.get("frequency", float("nan"))))
        self.f1 = float(sh.get("ramp_to", self.f0))
        self.ramp_start = float(sh.get("ramp_start", 0.0))
        self.ramp_time = float(sh.get("ramp_time", 0.0))
        self.startup_cycles = float(sh.get("startup_cycles", 0.0))
        self.settle = float((run.scene.get("run", {}) or {}).get("settle", attrs.get("settle", 0.0)))
        if not (self.f0 > 0):
            raise ValueError(f"{run.path}: no shaking frequency in scene_json or attributes")
        if self.ramp_time <= 0:
            self.f1 = self.f0

    def phase(self, t):
        u = np.asarray(t, dtype=np.float64) - self.settle
        u = np.maximum(u, 0.0)
        if self.ramp_time <= 0:
            return 2 * np.pi * self.f0 * u
        a = np.minimum(u, self.ramp_start)
        s = np.clip(u - self.ramp_start, 0.0, self.ramp_time)
        b = np.maximum(0.0, u - self.ramp_start - self.ramp_time)
        return 2 * np.pi * (self.f0 * a + self.f0 * s + 0.5 * (self.f1 - self.f0) * s * s / self.ramp_time
                            + self.f1 * b)

    def cycles(self, t):
        """Number of shaking cycles done at time t (0 before shaking)."""
        return self.phase(t) / (2 * np.pi)

    def envelope(self, t):
        t = np.asarray(t, dtype=np.float64)
        if self.startup_cycles <= 0:
            return np.where(t > self.settle, 1.0, 0.0)
        return np.clip(self.cycles(t) / self.startup_cycles, 0.0, 1.0)

    def y(self, t):
        """Floor-surface height y_box(t) (0 at rest)."""
        return self.amplitude * self.envelope(t) * np.sin(self.phase(t))


def box_y(run, t):
    """y_box(t) of the run's box (see :class:`Shaker`)."""
    return Shaker(run).y(t)


def _width(run):
    box = run.scene.get("box", {}) or {}
    w = box.get("width", run.attrs.get("box_width"))
    if w is None:
        raise ValueError(f"{run.path}: no box width in scene_json or attributes")
    return float(w)


def settled_frame(run):
    """Index of the frame at the end of settling (box still at rest): the last
    frame with time <= settle (+ a tenth of a period)."""
    sh = Shaker(run)
    t = run.frames.time
    idx = np.nonzero(t <= sh.settle + 0.1 / sh.f0)[0]
    if idx.size == 0:
        raise ValueError(f"{run.path}: no frame at the end of settling (t <= {sh.settle})")
    return int(idx[-1])


def node_frames(run, tol=0.05):
    """Frames taken at a node of the vibration during shaking.

    Returns (indices, cycle numbers): frames after the start of shaking whose
    cycle count phi/2pi is within ``tol`` of a whole number n >= 1.  If two
    frames round to the same n (a final frame just after a node), the one
    closer to the node is kept.
    """
    sh = Shaker(run)
    t = run.frames.time
    c = sh.cycles(t)
    n = np.rint(c)
    ok = (t > sh.settle) & (n >= 1) & (np.abs(c - n) < tol)
    best = {}
    for i in np.nonzero(ok)[0]:
        k = int(n[i])
        if k not in best or abs(c[i] - k) < abs(c[best[k]] - k):
            best[k] = int(i)
    cyc = np.array(sorted(best), dtype=np.int64)
    return np.array([best[k] for k in cyc], dtype=np.int64), cyc


def _pairs(run, skip_cycles, max_cycles=None, last=None):
    """Consecutive node-frame pairs (i, j, cycles between them) whose earlier
    node is at cycle n >= skip_cycles (and n < skip_cycles + max_cycles if
    given); with ``last``, only the last ``last`` of those pairs."""
    idx, cyc = node_frames(run)
    pairs = []
    for k in range(len(idx) - 1):
        if cyc[k] < skip_cycles or (max_cycles is not None and cyc[k] >= skip_cycles + max_cycles):
            continue
        pairs.append((int(idx[k]), int(idx[k + 1]), int(cyc[k + 1] - cyc[k])))
    if last is not None:
        pairs = pairs[len(pairs) - int(last):] if 0 < last < len(pairs) else (pairs if last > 0 else [])
    return pairs


def bed_height(run, percentile=95.0):
    """Height of the settled packing's surface above the floor: the given
    percentile of y + d/2 over the small disks in the frame at the end of
    settling (box at rest, floor surface at y = 0)."""
    f = settled_frame(run)
    fr = run.frames
    small = fr.species[f] == SMALL
    if not np.any(small):
        raise ValueError(f"{run.path}: no small disks in the settled frame")
    top = fr.position[f, small, 1] + 0.5 * fr.diameter[f, small] - float(Shaker(run).y(fr.time[f]))
    return float(np.percentile(top, percentile))


def read_forces(run):
    """(F, N, dim) contact forces from /frames/force, columns matched to
    ``run.frames`` (sorted by id).  Uses ``run.frames.force`` if the reader
    provides it.  Raises ValueError if the file has no forces."""
    f = getattr(run.frames, "force", None)
    if f is not None:
        return np.asarray(f, dtype=np.float64)
    with open_h5(run.path) as h5:
        if "frames/force" not in h5:
            raise ValueError(f"{run.path}: no /frames/force in the file")
        n = run.frames.n_frames  # complete frames (compare.reader)
        force = h5["frames/force"][:n].astype(np.float64)
        ids = h5["frames/id"][:n]
    if force.shape[:2] != ids.shape:
        raise ValueError(f"{run.path}: /frames/force has shape {force.shape}, /frames/id {ids.shape}")
    order = np.argsort(ids, axis=1, kind="stable")
    return np.take_along_axis(force, order[:, :, None], axis=1)


def read_trace(run):
    """The big disk's trace as a dict of arrays, or None if the file has none."""
    return read_series(run.path, "trace")


def _big_column(run):
    sp = run.frames.species[0] if run.frames.n_frames else np.zeros(0)
    cols = np.nonzero(sp == BIG)[0]
    return int(cols[0]) if cols.size else None


def _crossing(t, z, level, k):
    """Time where z crosses `level` between samples k-1 and k (linear)."""
    if k == 0:
        return float(t[0])
    z0, z1 = z[k - 1], z[k]
    if z1 == z0:
        return float(t[k])
    return float(t[k - 1] + (level - z0) / (z1 - z0) * (t[k] - t[k - 1]))


def _running_mean(x, w):
    """Centred running mean over w samples (window shrinks at the ends)."""
    x = np.asarray(x, dtype=np.float64)
    if w <= 1 or x.size == 0:
        return x.copy()
    h = w // 2
    c = np.concatenate([[0.0], np.cumsum(x)])
    i = np.arange(x.size)
    lo = np.maximum(0, i - h)
    hi = np.minimum(x.size, i + h + 1)
    return (c[hi] - c[lo]) / (hi - lo)


# --------------------------------------------------------------------------- 1. big-disk height

class BigDiskHeight(Result):
    """Height of the big disk's bottom above the floor surface, h = y_big - R_big - y_box.

    The rise is located on the normalised height z = (h - h0) / (h_top - h0):
    h0 = median h over the first cycle of shaking (the disk at the floor),
    h_top = H - 2 R_big (the disk's top level with the settled bed surface H).
    z is first smoothed by a centred running mean over ``smooth_cycles`` cycles
    (removes the disk's bouncing within a cycle).

    * t_hi: first time z >= rise_fraction (the disk has reached the top region);
    * t_lo: the last upward crossing of z = start_fraction before t_hi (the rise
      "for good": false starts that fall back are ignored);
    * the rise between the two crossings is extrapolated linearly to z = 0 and
      z = 1: rise_time = (t_hi - t_lo) / (rise_fraction - start_fraction),
      waiting_time = t_lo - start_fraction * rise_time (clipped at 0),
      both in seconds of shaking.

    If z never reaches rise_fraction, waiting and rise times are None and
    reached_top is False.
    """

    def __init__(self, rise_fraction=0.8, start_fraction=0.2, smooth_cycles=1.0):
        if not 0 < start_fraction < rise_fraction <= 1.5:
            raise ValueError("need 0 < start_fraction < rise_fraction")
        self.rise_fraction = float(rise_fraction)
        self.start_fraction = float(start_fraction)
        self.smooth_cycles = float(smooth_cycles)
        self._result = None

    def compute(self, run):
        tr = read_trace(run)
        if tr is None or "big_position" not in tr:
            raise ValueError(f"{run.path}: no /trace (a run with a big disk is needed)")
        col = _big_column(run)
        if col is None:
            raise ValueError(f"{run.path}: no big disk (species 1) in the frames")
        sh = Shaker(run)
        f_set = settled_frame(run)
        r_big = 0.5 * float(run.frames.diameter[f_set, col])
        H = bed_height(run)
        t = tr["time"]
        ts = t - sh.settle
        ybox = tr["box_y"] if "box_y" in tr else sh.y(t)
        h = tr["big_position"][:, 1] - r_big - ybox
        cyc = tr["cycle"] if "cycle" in tr else sh.cycles(t)
        per_cycle = 1.0 / np.median(np.diff(cyc)) if cyc.size > 1 else 1.0
        w = max(1, int(round(self.smooth_cycles * per_cycle)))
        hs = _running_mean(h, w)
        first = cyc <= (cyc[0] + 1.0) if cyc.size else np.zeros(0, bool)
        h0 = float(np.median(h[first])) if h.size else float("nan")
        h_top = H - 2 * r_big
        res = {"times_s": ts, "height": h, "height_smoothed": hs, "bed_height": H, "big_radius": r_big,
               "start_height": h0, "top_height": h_top, "waiting_time_s": None, "rise_time_s": None,
               "start_crossing_s": None, "top_crossing_s": None, "reached_top": False,
               "cycle": cyc, "final_height": float(np.mean(hs[-w:])) if h.size else float("nan")}
        if h.size and h_top > h0:
            z = (hs - h0) / (h_top - h0)
            above = np.nonzero(z >= self.rise_fraction)[0]
            if above.size:
                k_hi = int(above[0])
                t_hi = _crossing(ts, z, self.rise_fraction, k_hi)
                below = np.nonzero(z[:k_hi] < self.start_fraction)[0]
                if below.size:
                    k_lo = int(below[-1]) + 1
                    t_lo = _crossing(ts, z, self.start_fraction, k_lo)
                else:  # already above start_fraction at the first sample
                    t_lo = float(ts[0])
                rise = (t_hi - t_lo) / (self.rise_fraction - self.start_fraction)
                res.update(reached_top=True, top_crossing_s=t_hi, start_crossing_s=t_lo, rise_time_s=rise,
                           waiting_time_s=max(0.0, t_lo - self.start_fraction * rise))
        self._result = res
        return self

    times_s = property(lambda self: self._get("times_s"), doc="(T,) seconds since shaking started.")
    height = property(lambda self: self._get("height"), doc="(T,) h = y_big - R_big - y_box (cm).")
    height_smoothed = property(lambda self: self._get("height_smoothed"),
                               doc="(T,) h after the running mean over smooth_cycles cycles.")
    bed_height = property(lambda self: self._get("bed_height"), doc="H: settled bed surface (cm).")
    big_radius = property(lambda self: self._get("big_radius"))
    start_height = property(lambda self: self._get("start_height"), doc="h0: median h in cycle 1.")
    top_height = property(lambda self: self._get("top_height"), doc="H - 2 R_big.")
    waiting_time_s = property(lambda self: self._get("waiting_time_s"),
                              doc="Seconds of shaking before the rise starts, None if never reached the top.")
    rise_time_s = property(lambda self: self._get("rise_time_s"),
                           doc="Seconds from the start of the rise to the top, None if never.")
    start_crossing_s = property(lambda self: self._get("start_crossing_s"))
    top_crossing_s = property(lambda self: self._get("top_crossing_s"))
    reached_top = property(lambda self: self._get("reached_top"))
    final_height = property(lambda self: self._get("final_height"),
                            doc="Smoothed h averaged over the last cycle.")

    def plot(self, ax=None):
        """h against seconds of shaking (Poeschel and Herrmann Fig. 4)."""
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(7, 4))
        ax.plot(self.times_s, self.height, lw=0.5, color="0.6", label="h(t)")
        ax.plot(self.times_s, self.height_smoothed, lw=1.2, color="k", label="1-cycle mean")
        ax.axhline(self.top_height, ls="--", color="tab:red", lw=0.8, label="H - 2R (top)")
        ax.axhline(0.0, ls=":", color="0.4", lw=0.8)
        if self.reached_top:
            w, r = self.waiting_time_s, self.rise_time_s
            ax.axvline(w, color="tab:blue", lw=0.8, label=f"waiting {w:.1f} s")
            ax.axvline(w + r, color="tab:green", lw=0.8, label=f"rise {r:.1f} s")
        ax.set_xlabel("time of shaking (s)")
        ax.set_ylabel("height of big disk above floor (cm)")
        ax.legend(fontsize=8, loc="best")
        return ax

    def as_dict(self):
        ts = self.times_s
        cyc = np.floor(self._get("cycle")).astype(np.int64) if ts.size else np.zeros(0, np.int64)
        per = {}
        for c in np.unique(cyc):  # compact curve: one mean per cycle
            m = cyc == c
            per[int(c)] = (float(ts[m].mean()), float(self.height[m].mean()))
        return clean_json({
            "params": {"rise_fraction": self.rise_fraction, "start_fraction": self.start_fraction,
                       "smooth_cycles": self.smooth_cycles},
            "bed_height": self.bed_height, "big_radius": self.big_radius, "start_height": self.start_height,
            "top_height": self.top_height, "waiting_time_s": self.waiting_time_s,
            "rise_time_s": self.rise_time_s, "start_crossing_s": self.start_crossing_s,
            "top_crossing_s": self.top_crossing_s, "reached_top": bool(self.reached_top),
            "final_height": self.final_height,
            "cycle_time_s": [v[0] for v in per.values()], "cycle_mean_height": [v[1] for v in per.values()],
        })


# --------------------------------------------------------------------------- 2. convective flux

class ConvectiveFlux(Result):
    """Net particle flux through horizontal lines, Phi(D) = j_centre(D) - j_wall(D).

    ``lines`` lines at heights D_k = (k - 1/2) H / lines above the floor
    (k = 1..lines, H the settled bed height).  For each pair of consecutive
    node frames (one cycle apart) after ``skip_cycles`` cycles of shaking, each
    small or big disk with y_a <= D < y_b (heights above the floor, y - y_box)
    contributes +1 (upward) and with y_b <= D < y_a contributes -1 to line D,
    in the centre region if |x_mid| < centre_fraction W / 2 (x_mid the mean x of
    the two frames), else in the wall region.  j = net count / cycles between
    the frames, averaged over pairs, in particles per cycle.  Phi > 0 for rolls
    going up in the centre and down at the walls.

    Noise: the standard error of Phi(D) over the pairs.  ``lowest_height`` is
    the lowest line reached going down from the most significant line while
    Phi > noise_sigma * SE stays true; ``depth`` = H - lowest_height (how far
    below the settled surface the rolls reach; None if no line is significant).
    """

    def __init__(self, lines=80, centre_fraction=0.5, skip_cycles=5, max_cycles=None, noise_sigma=3.0):
        if lines < 1:
            raise ValueError("lines must be >= 1")
        if not 0 < centre_fraction < 1:
            raise ValueError("centre_fraction must be in (0, 1)")
        self.lines = int(lines)
        self.centre_fraction = float(centre_fraction)
        self.skip_cycles = int(skip_cycles)
        self.max_cycles = None if max_cycles is None else int(max_cycles)
        self.noise_sigma = float(noise_sigma)
        self._result = None

    def compute(self, run):
        sh = Shaker(run)
        H = bed_height(run)
        W = _width(run)
        heights = (np.arange(self.lines) + 0.5) * H / self.lines
        pairs = _pairs(run, self.skip_cycles, self.max_cycles)
        fr = run.frames
        grains = (fr.species[0] == SMALL) | (fr.species[0] == BIG)
        jc, jw = [], []
        for a, b, dc in pairs:
            ya = fr.position[a, grains, 1] - sh.y(fr.time[a])
            yb = fr.position[b, grains, 1] - sh.y(fr.time[b])
            xm = 0.5 * (fr.position[a, grains, 0] + fr.position[b, grains, 0])
            centre = np.abs(xm) < self.centre_fraction * 0.5 * W
            # n = number of lines strictly below y; a disk is above line k iff k < n.
            # Net upward crossings of line k = #(n_b > k) - #(n_a > k).
            na = np.searchsorted(heights, ya, side="left")
            nb = np.searchsorted(heights, yb, side="left")
            row = []
            for sel in (centre, ~centre):
                total = int(sel.sum())
                above_a = total - np.cumsum(np.bincount(na[sel], minlength=self.lines + 1))[:self.lines]
                above_b = total - np.cumsum(np.bincount(nb[sel], minlength=self.lines + 1))[:self.lines]
                row.append((above_b - above_a) / dc)
            jc.append(row[0])
            jw.append(row[1])
        jc = np.array(jc, dtype=np.float64).reshape(-1, self.lines)
        jw = np.array(jw, dtype=np.float64).reshape(-1, self.lines)
        n = jc.shape[0]
        phi_pairs = jc - jw
        with np.errstate(invalid="ignore", divide="ignore"):
            j_c = jc.mean(axis=0) if n else np.full(self.lines, np.nan)
            j_w = jw.mean(axis=0) if n else np.full(self.lines, np.nan)
            phi = phi_pairs.mean(axis=0) if n else np.full(self.lines, np.nan)
            se = phi_pairs.std(axis=0, ddof=1) / math.sqrt(n) if n > 1 else np.full(self.lines, np.nan)
        lowest = None
        sig = phi > self.noise_sigma * se
        if n > 1 and np.any(sig):
            with np.errstate(invalid="ignore", divide="ignore"):
                score = np.where(se > 0, phi / se, np.where(phi > 0, np.inf, -np.inf))
            k = int(np.argmax(np.where(sig, score, -np.inf)))
            while k > 0 and sig[k - 1]:
                k -= 1
            lowest = float(heights[k])
        self._result = {
            "heights": heights, "spacing": H / self.lines, "bed_height": H, "j_centre": j_c, "j_wall": j_w,
            "phi": phi, "phi_se": se, "cycles_used": int(sum(p[2] for p in pairs)), "pairs_used": n,
            "phi_max": float(np.nanmax(phi)) if n else None,
            "height_of_max": float(heights[int(np.nanargmax(phi))]) if n else None,
            "lowest_height": lowest, "depth": None if lowest is None else H - lowest,
        }
        return self

    heights = property(lambda self: self._get("heights"), doc="(lines,) line heights D above the floor (cm).")
    spacing = property(lambda self: self._get("spacing"), doc="Distance between lines, H / lines.")
    bed_height = property(lambda self: self._get("bed_height"))
    j_centre = property(lambda self: self._get("j_centre"), doc="(lines,) net upward flux, centre, per cycle.")
    j_wall = property(lambda self: self._get("j_wall"), doc="(lines,) net upward flux, wall region, per cycle.")
    phi = property(lambda self: self._get("phi"), doc="(lines,) Phi = j_centre - j_wall, particles per cycle.")
    phi_se = property(lambda self: self._get("phi_se"), doc="(lines,) standard error of Phi over pairs.")
    cycles_used = property(lambda self: self._get("cycles_used"))
    pairs_used = property(lambda self: self._get("pairs_used"))
    phi_max = property(lambda self: self._get("phi_max"), doc="max over D of Phi (None without pairs).")
    height_of_max = property(lambda self: self._get("height_of_max"))
    lowest_height = property(lambda self: self._get("lowest_height"),
                             doc="Lowest D of the significant region around the maximum (None if none).")
    depth = property(lambda self: self._get("depth"), doc="H - lowest_height (None if not significant).")

    def plot(self, ax=None):
        """Phi on x, D on y (Poeschel and Herrmann Fig. 3)."""
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(4, 6))
        D, phi, se = self.heights, self.phi, self.phi_se
        if np.all(np.isfinite(se)):
            ax.fill_betweenx(D, phi - self.noise_sigma * se, phi + self.noise_sigma * se, color="0.85",
                             label=f"±{self.noise_sigma:g} s.e.")
        ax.plot(phi, D, "k-", lw=1.2, label="Φ")
        ax.axvline(0.0, color="0.4", lw=0.6)
        if self.lowest_height is not None:
            ax.axhline(self.lowest_height, ls="--", color="tab:red", lw=0.8, label="lowest significant D")
        ax.set_xlabel("Φ (particles / cycle)")
        ax.set_ylabel("height D above floor (cm)")
        ax.set_ylim(0, self.bed_height)
        ax.legend(fontsize=8, loc="best")
        return ax

    def as_dict(self):
        return clean_json({
            "params": {"lines": self.lines, "centre_fraction": self.centre_fraction,
                       "skip_cycles": self.skip_cycles, "max_cycles": self.max_cycles,
                       "noise_sigma": self.noise_sigma},
            "bed_height": self.bed_height, "cycles_used": self.cycles_used, "pairs_used": self.pairs_used,
            "phi_max": self.phi_max, "height_of_max": self.height_of_max, "lowest_height": self.lowest_height,
            "depth": self.depth, "heights": self.heights, "phi": self.phi, "phi_se": self.phi_se,
            "j_centre": self.j_centre, "j_wall": self.j_wall,
        })


# --------------------------------------------------------------------------- 3. velocity field

class VelocityField(Result):
    """Stroboscopic drift velocity of the grains, averaged over the last ``periods`` cycles.

    For each consecutive pair of node frames (after ``skip_cycles``), each small
    or big disk contributes v = (r_b - r_a) / (t_b - t_a) at its mid-point
    position (relative to the floor).  The samples are averaged in a grid of
    ``cells`` = (nx, ny) cells over -W/2 <= x <= W/2, 0 <= y <= y_max, with
    y_max = ``height`` or, by default, 1.2 H (H the settled bed height: room for
    the dilated bed, without the sparse cells of grains thrown far above it).
    Cells with fewer than ``min_count`` samples are NaN.
    """

    def __init__(self, cells=(20, 30), periods=50, skip_cycles=5, min_count=3, height=None):
        self.cells = (int(cells[0]), int(cells[1]))
        if min(self.cells) < 1:
            raise ValueError("cells must be positive")
        self.periods = int(periods)
        self.skip_cycles = int(skip_cycles)
        self.min_count = int(min_count)
        self.height = None if height is None else float(height)
        self._result = None

    def compute(self, run):
        sh = Shaker(run)
        W = _width(run)
        fr = run.frames
        grains = (fr.species[0] == SMALL) | (fr.species[0] == BIG)
        pairs = _pairs(run, self.skip_cycles, last=self.periods)
        xs, ys, vs = [], [], []
        for a, b, _ in pairs:
            ra = fr.position[a, grains].copy()
            rb = fr.position[b, grains].copy()
            ra[:, 1] -= sh.y(fr.time[a])
            rb[:, 1] -= sh.y(fr.time[b])
            dt = fr.time[b] - fr.time[a]
            mid = 0.5 * (ra + rb)
            xs.append(mid[:, 0])
            ys.append(mid[:, 1])
            vs.append((rb - ra) / dt)
        nx, ny = self.cells
        ymax = self.height if self.height is not None else 1.2 * bed_height(run)
        xe = np.linspace(-0.5 * W, 0.5 * W, nx + 1)
        ye = np.linspace(0.0, ymax, ny + 1)
        if pairs:
            x, y, v = np.concatenate(xs), np.concatenate(ys), np.concatenate(vs)
        else:
            x = y = np.zeros(0)
            v = np.zeros((0, 2))
        count, _, _ = np.histogram2d(y, x, bins=(ye, xe))
        vx, _, _ = np.histogram2d(y, x, bins=(ye, xe), weights=v[:, 0])
        vy, _, _ = np.histogram2d(y, x, bins=(ye, xe), weights=v[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            field = np.stack([vx / count, vy / count], axis=-1)
        field[count < max(1, self.min_count)] = np.nan
        # summary numbers: mean vertical drift in the centre half and near the walls
        inside = (y >= 0) & (y <= ymax)
        centre = inside & (np.abs(x) < 0.25 * W)
        wall = inside & ~centre
        self._result = {
            "x_edges": xe, "y_edges": ye, "velocity": field, "count": count.astype(np.int64),
            "periods_used": len(pairs),
            "mean_speed": float(np.mean(np.hypot(v[:, 0], v[:, 1]))) if len(v) else float("nan"),
            "centre_vy": float(v[centre, 1].mean()) if centre.any() else float("nan"),
            "wall_vy": float(v[wall, 1].mean()) if wall.any() else float("nan"),
        }
        return self

    x_edges = property(lambda self: self._get("x_edges"))
    y_edges = property(lambda self: self._get("y_edges"), doc="Cell edges in height above the floor.")
    velocity = property(lambda self: self._get("velocity"),
                        doc="(ny, nx, 2) mean drift velocity (cm/s), NaN in sparse cells.")
    count = property(lambda self: self._get("count"), doc="(ny, nx) number of particle-cycle samples.")
    periods_used = property(lambda self: self._get("periods_used"))
    mean_speed = property(lambda self: self._get("mean_speed"), doc="Mean |v| over all samples (cm/s).")
    centre_vy = property(lambda self: self._get("centre_vy"), doc="Mean v_y of samples with |x| < W/4.")
    wall_vy = property(lambda self: self._get("wall_vy"), doc="Mean v_y of samples with |x| >= W/4.")

    @property
    def x_centres(self):
        e = self.x_edges
        return 0.5 * (e[1:] + e[:-1])

    @property
    def y_centres(self):
        e = self.y_edges
        return 0.5 * (e[1:] + e[:-1])

    def plot(self, ax=None):
        """Quiver plot of the drift field (Poeschel and Herrmann Fig. 1)."""
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(5, 6))
        X, Y = np.meshgrid(self.x_centres, self.y_centres)
        v = self.velocity
        ok = np.isfinite(v[..., 0])
        if ok.any():
            ax.quiver(X[ok], Y[ok], v[..., 0][ok], v[..., 1][ok], angles="xy", pivot="mid")
        else:
            ax.text(0.5, 0.5, "no samples", transform=ax.transAxes, ha="center", va="center")
        ax.set_xlim(self.x_edges[0], self.x_edges[-1])
        ax.set_ylim(self.y_edges[0], self.y_edges[-1])
        ax.set_aspect("equal")
        ax.set_xlabel("x (cm)")
        ax.set_ylabel("height above floor (cm)")
        ax.set_title(f"drift velocity, {self.periods_used} cycles")
        return ax

    def as_dict(self):
        return clean_json({
            "params": {"cells": list(self.cells), "periods": self.periods, "skip_cycles": self.skip_cycles,
                       "min_count": self.min_count, "height": self.height},
            "periods_used": self.periods_used, "mean_speed": self.mean_speed, "centre_vy": self.centre_vy,
            "wall_vy": self.wall_vy, "x_edges": self.x_edges, "y_edges": self.y_edges,
            "vx": self.velocity[..., 0], "vy": self.velocity[..., 1], "count": self.count,
        })


# --------------------------------------------------------------------------- 4. force ratio

class ForceRatio(Result):
    """Mean |F| on small disks in a ring inner <= |r - r_big| <= outer around the big disk.

    Frames: node frames of shaking after ``skip_cycles`` (forces are only
    stored in snapshots, so these are forces at phase 0 of the vibration).
    With a ``reference`` run (same scene without the big disk) the same ring is
    placed, frame by frame, at the big disk's position relative to the floor in
    the first run's node frame of the same cycle number (``match="frame"``; a
    reference frame without a counterpart uses the mean position), or at the
    big disk's mean position over the frames used (``match="mean"``).
    ratio = mean_with / mean_without.  Errors are standard errors over frames
    (the per-frame ring means), propagated to the ratio.

    Readings of the paper's "sum of the absolute values of the forces ...
    averaged over time": ``force="contact"`` takes |F| of each disk's net
    contact force (the engine's /frames/force; at rest it carries the disk's
    weight), ``force="total"`` adds gravity, |F + m g| = m |a| (the
    acceleration the paper's explanation speaks of); ``phases="node"`` uses
    the frames at phase 0 of the vibration, ``phases="all"`` every frame after
    ``skip_cycles`` (a run written several frames per cycle averages over the
    phases); ``half="lower"`` or ``"upper"`` keeps the half of the ring below
    or above the big disk's centre (the paper: "strongest in the lower part").
    """

    def __init__(self, inner=4.5, outer=8.0, skip_cycles=5, match="frame", force="contact", phases="node",
                 half=None):
        if not 0 <= inner < outer:
            raise ValueError("need 0 <= inner < outer")
        if match not in ("frame", "mean"):
            raise ValueError("match must be 'frame' or 'mean'")
        if force not in ("contact", "total") or phases not in ("node", "all") or half not in (None, "lower", "upper"):
            raise ValueError("force: contact|total, phases: node|all, half: None|lower|upper")
        self.force, self.phases, self.half = force, phases, half
        self.inner = float(inner)
        self.outer = float(outer)
        self.skip_cycles = int(skip_cycles)
        self.match = match
        self._result = None

    def _frames(self, run):
        """Frame indices and their keys: the cycle number (node frames) or the
        cycle count in thousandths (every frame), equal in two runs of the same
        scene and cadence."""
        if self.phases == "node":
            idx, cyc = node_frames(run)
            keep = cyc >= self.skip_cycles
            return idx[keep], cyc[keep]
        c = Shaker(run).cycles(run.frames.time)
        idx = np.nonzero(c >= self.skip_cycles)[0]
        return idx, np.round(c[idx] * 1000).astype(np.int64)

    def _ring_means(self, run, centres):
        """Per-frame mean |F| of small disks in the ring; centres: {frame: (x, y_rel)}."""
        sh = Shaker(run)
        force = read_forces(run)
        fr = run.frames
        if self.force == "total":  # m a = contact force + m g (g along -y)
            pt = run.scene.get("particles", {})
            area = np.pi * (0.5 * fr.diameter) ** 2 * (1.0 if pt.get("mass_rule") == "area" else 2.0)
            mass = area * float(pt.get("density", 1.0))
            force = force.copy()
            force[..., 1] -= mass * float(run.scene.get("gravity", {}).get("g", 981.0))
        means, counts = [], []
        for f, c in centres.items():
            small = fr.species[f] == SMALL
            r = fr.position[f, small].copy()
            r[:, 1] -= float(sh.y(fr.time[f]))
            dist = np.hypot(r[:, 0] - c[0], r[:, 1] - c[1])
            ring = (dist >= self.inner) & (dist <= self.outer)
            if self.half is not None:
                ring &= (r[:, 1] < c[1]) if self.half == "lower" else (r[:, 1] >= c[1])
            if ring.any():
                fm = np.hypot(force[f, small][ring, 0], force[f, small][ring, 1])
                means.append(fm.mean())
                counts.append(int(ring.sum()))
        return np.array(means), np.array(counts, dtype=np.int64)

    @staticmethod
    def _stats(means, counts):
        if counts.sum() == 0:
            return float("nan"), float("nan")
        mean = float(np.sum(means * counts) / counts.sum())  # mean over all (frame, disk) samples
        se = float(np.std(means, ddof=1) / math.sqrt(len(means))) if len(means) > 1 else float("nan")
        return mean, se

    def compute(self, run, reference=None):
        col = _big_column(run)
        if col is None:
            raise ValueError(f"{run.path}: ForceRatio needs a run with a big disk (species 1)")
        sh = Shaker(run)
        idx, cyc = self._frames(run)
        fr = run.frames
        pos = {int(c): (fr.position[f, col, 0], fr.position[f, col, 1] - float(sh.y(fr.time[f])))
               for f, c in zip(idx, cyc)}
        m_with, n_with = self._ring_means(run, {int(f): pos[int(c)] for f, c in zip(idx, cyc)})
        mean_with, se_with = self._stats(m_with, n_with)
        mean_pos = np.mean(np.array(list(pos.values())), axis=0) if pos else np.array([np.nan, np.nan])
        res = {"mean_with": mean_with, "se_with": se_with, "frames_with": len(m_with),
               "samples_with": int(n_with.sum()), "big_mean_position": mean_pos,
               "mean_without": None, "se_without": None, "frames_without": 0, "samples_without": 0,
               "ratio": None, "ratio_se": None}
        if reference is not None:
            if not hasattr(reference, "frames"):
                from .reader import read_run
                reference = read_run(reference)
            ridx, rcyc = self._frames(reference)
            centres = {}
            for f, c in zip(ridx, rcyc):
                if self.match == "frame" and int(c) in pos:
                    centres[int(f)] = pos[int(c)]
                else:
                    centres[int(f)] = tuple(mean_pos)
            m0, n0 = self._ring_means(reference, centres)
            mean0, se0 = self._stats(m0, n0)
            ratio = mean_with / mean0 if mean0 and math.isfinite(mean0) else float("nan")
            rse = ratio * math.sqrt((se_with / mean_with) ** 2 + (se0 / mean0) ** 2) \
                if math.isfinite(ratio) and mean_with else float("nan")
            res.update(mean_without=mean0, se_without=se0, frames_without=len(m0),
                       samples_without=int(n0.sum()), ratio=ratio, ratio_se=rse)
        self._result = res
        return self

    mean_with = property(lambda self: self._get("mean_with"), doc="Mean |F| in the ring, this run (dyn).")
    se_with = property(lambda self: self._get("se_with"))
    mean_without = property(lambda self: self._get("mean_without"), doc="Same ring in the reference run.")
    se_without = property(lambda self: self._get("se_without"))
    ratio = property(lambda self: self._get("ratio"), doc="mean_with / mean_without (None without reference).")
    ratio_se = property(lambda self: self._get("ratio_se"))
    frames_with = property(lambda self: self._get("frames_with"))
    frames_without = property(lambda self: self._get("frames_without"))
    big_mean_position = property(lambda self: self._get("big_mean_position"))

    def plot(self, ax=None):
        """Bar chart of the two ring means with their standard errors."""
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(4, 4))
        vals = [self.mean_with] + ([self.mean_without] if self.mean_without is not None else [])
        errs = [self.se_with] + ([self.se_without] if self.mean_without is not None else [])
        labels = ["with big disk", "without"][:len(vals)]
        ax.bar(labels, vals, yerr=[e if e is not None and math.isfinite(e) else 0 for e in errs],
               color=["tab:red", "tab:blue"][:len(vals)], capsize=4)
        ax.set_ylabel(f"mean |F| of small disks, ring {self.inner:g}-{self.outer:g} cm (dyn)")
        if self.ratio is not None:
            ax.set_title(f"ratio {self.ratio:.3f}")
        return ax

    def as_dict(self):
        self._get("ratio")  # raises before compute
        return clean_json(dict({"params": {"inner": self.inner, "outer": self.outer,
                                       "skip_cycles": self.skip_cycles, "match": self.match, "force": self.force,
                                       "phases": self.phases, "half": self.half}},
                           **self._result))


# --------------------------------------------------------------------------- 5. onset frequency

def onset_fraction(rose, confidence=0.95):
    """Fraction of packings in which the big disk reached the top, with the
    Clopper-Pearson (exact) binomial interval.  Returns (fraction, lo, hi)."""
    from scipy.stats import binomtest
    rose = [bool(r) for r in rose]
    n = len(rose)
    if n == 0:
        raise ValueError("onset_fraction needs at least one packing")
    k = sum(rose)
    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
    return k / n, float(ci.low), float(ci.high)


def _crossings(f, p, level):
    """Frequencies where the piecewise-linear curve p(f) crosses `level` going
    up (p[i] < level <= p[i+1]), linearly interpolated."""
    return [float(f[i] + (level - p[i]) / (p[i + 1] - p[i]) * (f[i + 1] - f[i]))
            for i in range(len(f) - 1) if p[i] < level <= p[i + 1]]


def onset_threshold(freqs, successes, trials, confidence=0.95, level=0.5):
    """Onset frequency: where the fraction of packings whose big disk reached
    the top crosses ``level`` (1/2), by linear interpolation between grid
    frequencies (the first upward crossing if the fractions are not monotonic).

    Interval: the same interpolation applied to the per-frequency
    Clopper-Pearson bounds.  The lower end ``lo`` is the first upward crossing
    of the upper bound hi(f) (below it every grid fraction is significantly
    below 1/2); the upper end ``hi`` is the last upward crossing of the lower
    bound lo(f) (above it every grid fraction is significantly above 1/2).

    Outside the grid: ``threshold`` is None and ``threshold_position`` says
    "below_grid" (fraction >= 1/2 already at the lowest frequency) or
    "above_grid" (never reaches 1/2).  ``lo`` is None if hi(f) >= 1/2 already
    at the lowest frequency (unbounded below) and is the highest frequency if
    hi(f) never reaches 1/2; ``hi`` is None if lo(f) ends below 1/2 (unbounded
    above) and is the lowest frequency if lo(f) >= 1/2 everywhere.

    Returns a JSON-safe dict: threshold, lo, hi, threshold_position and the
    per-frequency freqs, successes, trials, fraction, ci_lo, ci_hi.
    """
    f = np.asarray(freqs, dtype=np.float64)
    k = np.asarray(successes, dtype=np.int64)
    n = np.asarray(trials, dtype=np.int64)
    if not (f.shape == k.shape == n.shape) or f.ndim != 1 or f.size == 0:
        raise ValueError("freqs, successes and trials must be equal-length, non-empty 1-D sequences")
    if np.any(n <= 0) or np.any(k < 0) or np.any(k > n):
        raise ValueError("need 0 <= successes <= trials and trials > 0")
    if np.unique(f).size != f.size:
        raise ValueError("freqs must be distinct (pool the packings of one frequency)")
    order = np.argsort(f)
    f, k, n = f[order], k[order], n[order]
    stats = [onset_fraction([True] * int(ki) + [False] * int(ni - ki), confidence) for ki, ni in zip(k, n)]
    p = np.array([s[0] for s in stats])
    ci_lo = np.array([s[1] for s in stats])
    ci_hi = np.array([s[2] for s in stats])

    if p[0] >= level:
        thr, where = None, "below_grid"
    else:
        c = _crossings(f, p, level)
        thr, where = (c[0], "in_grid") if c else (None, "above_grid")
    if ci_hi[0] >= level:
        lo = None
    else:
        c = _crossings(f, ci_hi, level)
        lo = c[0] if c else float(f[-1])
    if ci_lo[-1] < level:
        hi = None
    else:
        c = _crossings(f, ci_lo, level)
        hi = c[-1] if c else float(f[0])
    return clean_json({
        "threshold": thr, "threshold_position": where, "lo": lo, "hi": hi, "level": level,
        "confidence": confidence, "freqs": f, "successes": k, "trials": n, "fraction": p,
        "ci_lo": ci_lo, "ci_hi": ci_hi,
    })


# --------------------------------------------------------------------------- 6. everything of one run

def observe_box(run, reference=None):
    """JSON-safe results of every shaken-box observable of one run.

    BigDiskHeight only if the run has a /trace; ForceRatio only if the run has
    a big disk (with ``reference``, a run or path without the big disk, the
    ratio is included)."""
    if not hasattr(run, "frames"):
        from .reader import read_run
        run = read_run(run)
    if run.attrs.get("scene_kind") != "shaken_box":
        raise ValueError(f"{run.path}: not a shaken-box run (scene_kind={run.attrs.get('scene_kind')!r})")
    out = {"scene_name": run.attrs.get("scene_name"), "frequency": Shaker(run).f0,
           "amplitude": Shaker(run).amplitude, "bed_height": bed_height(run),
           "node_frames": int(len(node_frames(run)[0]))}
    if read_trace(run) is not None and _big_column(run) is not None:
        out["big_disk_height"] = BigDiskHeight().compute(run).as_dict()
    out["convective_flux"] = ConvectiveFlux().compute(run).as_dict()
    out["velocity_field"] = VelocityField().compute(run).as_dict()
    if _big_column(run) is not None:
        out["force_ratio"] = ForceRatio().compute(run, reference=reference).as_dict()
    from .coulomb import BOX_SPECIES, CoulombCap, read_census
    if read_census(run.path) is not None:
        out["coulomb"] = CoulombCap(Shaker(run).settle, BOX_SPECIES).compute(run.path).as_dict()
    return clean_json(out)


def onset_from_runs(paths, within_s=None):
    """The rising fraction per frequency over a set of runs (one packing each)
    and the onset threshold: a run counts as risen if its big disk reached the
    top within ``within_s`` seconds of shaking (default: within the run)."""
    from .reader import read_run

    by_f = {}
    for p in paths:
        run = read_run(p)
        h = BigDiskHeight().compute(run)
        rose = bool(h.reached_top) and (within_s is None or h.top_crossing_s <= within_s)
        by_f.setdefault(round(Shaker(run).f0, 6), []).append(rose)
    freqs = sorted(by_f)
    res = onset_threshold(freqs, [sum(by_f[f]) for f in freqs], [len(by_f[f]) for f in freqs])
    res["within_s"] = within_s
    return res


def top_motion(height, min_top_s=5.0):
    """The big disk's up-and-down motion once it has reached the top
    (Poeschel and Herrmann, Fig. 4: "the large particle moves up and down at
    the top"). From the 1-cycle mean height after the first top crossing:

    * ``dip_depth``: how far below the top level the disk goes, the 90th
      percentile of (top - height) over that time, in cm, and as a fraction of
      the bed depth it rose through (``dip_fraction``);
    * ``regularity``: the height of the first peak of the autocorrelation of
      the height (after its first zero, at lags up to a third of the time at
      the top), 1 for a strictly periodic motion, near 0 for an irregular
      one; ``period_s`` is that peak's lag.

    ``height`` is a computed BigDiskHeight. None where the disk never reached
    the top or stayed there less than ``min_top_s`` seconds."""
    if not height.reached_top:
        return None
    t, h = height.times_s, height.height_smoothed
    sel = t >= height.top_crossing_s
    t, h = t[sel], h[sel]
    if t.size < 3 or t[-1] - t[0] < min_top_s:
        return None
    top = height.top_height
    below = top - h
    depth = float(np.percentile(below, 90))
    x = h - h.mean()
    acf = np.correlate(x, x, mode="full")[x.size - 1:]
    acf = acf / acf[0] if acf[0] > 0 else acf
    dt = float(np.median(np.diff(t)))
    zero = np.nonzero(acf <= 0)[0]
    regularity, period = 0.0, None
    max_lag = x.size // 3
    if zero.size and zero[0] < max_lag:
        rest = acf[zero[0]:max_lag]
        k = int(np.argmax(rest))
        if rest[k] > 0:
            regularity, period = float(rest[k]), float((zero[0] + k) * dt)
    span = top - height.start_height
    return {"seconds_at_top": float(t[-1] - t[0]), "dip_depth": depth,
            "dip_fraction": depth / span if span > 0 else None,
            "regularity": regularity, "period_s": period}
