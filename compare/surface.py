"""Free surface of the granular bed in the rotating drum and its slope angle
(Rapaport 2002, Fig. 9: "axially averaged surface heights across the system").

Definition (also in docs/observables.md, "Free surface and slope angle")
-------------------------------------------------------------------------
Coordinates: the drum axis is y, gravity is -z, and x runs across the drum
(perpendicular to the axis and to gravity).

1. Cells.  The x-y plane is tiled by cells of side ``cell`` over
   x in [-D/2, D/2] and y in [-L/2, L/2] (D = drum.diameter, L = drum.length).
   The number of cells along each direction is round(extent / cell), so the
   side is adjusted slightly (separately in x and y) to span the range
   exactly.  Particles are assigned to cells by their centre; with periodic
   ends y is first wrapped into [-L/2, L/2).
2. Surface particle.  In every cell holding at least one particle, the
   surface particle is the one whose top z + d/2 is highest; that top is the
   cell's surface height, and the surface particle's species is the cell's
   species.
3. Averaging.  h(x) of an x-column is the mean of the surface heights of its
   non-empty cells, over all y-cells and all frames used.  h_s(x) averages only
   the cells whose surface particle is of species s (NaN where there are
   none).  ``counts`` (``counts_by_species``) is the number of cells that
   contributed to each column.
4. Extent of the free surface.  A column belongs to the free surface if its
   h(x) is finite and lies below the wall by at least half a small diameter:
   h(x) < sqrt((D/2)^2 - x^2) - 0.5 (x = column centre).  Where the surface
   runs into the curved wall, the tops of the particles there are set by the
   wall, not by the free surface, and the criterion removes those columns.
   The extent is the contiguous run of such columns containing the column
   nearest x = 0 (if that column does not qualify: the longest run); it spans
   the cells' outer edges [x_first - w/2, x_last + w/2].
5. Fit.  The fit window is the central fraction ``fit_window`` of the extent,
   centred on the extent's midpoint.  A straight line h = a + b x is fitted by
   unweighted least squares to the column heights whose centres lie in the
   window (all species together, at least 3 columns); slope = b and
   slope_angle_deg = degrees(atan(|b|)).  The per-species angles come from
   the same kind of fit to h_s(x) over the same window (NaN if fewer than 3
   columns have a value).
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_SPECIES_NAMES = ("small", "big")
MIN_FIT_POINTS = 3
WALL_CLEARANCE = 0.5  # half a small diameter


def _fit_line(x, h):
    """Least-squares line h = a + b x over the finite points; (a, b, n) or NaNs."""
    x = np.asarray(x, dtype=np.float64)
    h = np.asarray(h, dtype=np.float64)
    ok = np.isfinite(h)
    n = int(ok.sum())
    if n < MIN_FIT_POINTS or np.ptp(x[ok]) == 0:
        return math.nan, math.nan, n
    b, a = np.polyfit(x[ok], h[ok], 1)
    return float(a), float(b), n


def _angle_deg(b):
    return math.degrees(math.atan(abs(b))) if math.isfinite(b) else math.nan


def _runs(mask):
    """(start, stop) index pairs of the contiguous True runs of a 1D bool array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _jsonable(v):
    """Floats / lists / dicts with NaN -> None."""
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_jsonable(x) for x in (v.tolist() if isinstance(v, np.ndarray) else v)]
    if isinstance(v, (np.integer, int)) and not isinstance(v, bool):
        return int(v)
    if isinstance(v, (np.floating, float)):
        return float(v) if math.isfinite(v) else None
    return v


class FreeSurface:
    """Axially averaged surface height h(x) across the drum and its slope angle.

    Follows the pattern of :class:`compare.spacetime.SpaceTime`: configure in
    the constructor, ``compute(run)`` returns self, results are read-only
    properties that raise RuntimeError until ``compute`` has been called.

    cell: side of the square x-y cells (default 1.0 = one small diameter).
    frames: number of snapshots averaged, the last ones of the run (default
        10, as in the paper's Fig. 9); None = all.
    fit_window: central fraction of the free-surface extent used for the
        straight-line fit (default 0.5), in (0, 1].
    min_gap_rotations: if given, the snapshots are chosen from the end of the
        run backwards, each at least this many rotations before the previously
        chosen one (the paper's "separated by several rotations").
    skip_rotations: snapshots before this many rotations (the collapse from
        the starting lattice, whose surface is flat) are not averaged
        (default 2.0). A run with no snapshot past it falls back to its last
        one, and ``settled`` is then False.
    """

    def __init__(self, cell=1.0, frames=10, fit_window=0.5, min_gap_rotations=None, skip_rotations=2.0):
        self.skip_rotations = float(skip_rotations)
        if self.skip_rotations < 0:
            raise ValueError(f"skip_rotations must be >= 0, got {skip_rotations!r}")
        self.cell = float(cell)
        if not self.cell > 0:
            raise ValueError(f"cell must be positive, got {cell!r}")
        if frames is not None:
            if int(frames) != frames or int(frames) < 1:
                raise ValueError(f"frames must be a positive integer or None, got {frames!r}")
            frames = int(frames)
        self.frames = frames
        self.fit_window = float(fit_window)
        if not 0 < self.fit_window <= 1:
            raise ValueError(f"fit_window must be in (0, 1], got {fit_window!r}")
        if min_gap_rotations is not None:
            min_gap_rotations = float(min_gap_rotations)
            if min_gap_rotations < 0:
                raise ValueError(f"min_gap_rotations must be >= 0, got {min_gap_rotations!r}")
        self.min_gap_rotations = min_gap_rotations
        self._result = None

    # -- computation -----------------------------------------------------------

    def _check_run(self, run):
        kind = run.attrs.get("scene_kind")
        if kind != "drum":
            raise ValueError(f"{run.path}: free-surface analysis needs a drum run "
                             f"(scene_kind={kind!r})")
        if run.dim != 3:
            raise ValueError(f"{run.path}: free-surface analysis needs a 3D run (dim={run.dim})")
        if run.frames.n_frames == 0:
            raise ValueError(f"{run.path}: run has no frames")
        try:
            diameter = float(run.scene["drum"]["diameter"])
            length = float(run.scene["drum"]["length"])
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{run.path}: scene_json has no drum.diameter / drum.length") from None
        if not (diameter > 0 and length > 0):
            raise ValueError(f"{run.path}: drum diameter {diameter} / length {length} must be positive")
        return diameter, length

    def _past_skip(self, time, period):
        """Whether times are at or past skip_rotations (float-tolerant)."""
        return time >= self.skip_rotations * period * (1 - 1e-9)

    def _select_frames(self, run):
        """Indices (ascending) of the snapshots to average."""
        time = run.frames.time
        n = time.size
        first = 0
        if run.rotation_period is not None and self.skip_rotations > 0:
            late = np.nonzero(self._past_skip(time, run.rotation_period))[0]
            first = int(late[0]) if late.size else n - 1
        want = (n - first) if self.frames is None else min(self.frames, n - first)
        if self.min_gap_rotations is None:
            return np.arange(n - want, n)
        if run.rotation_period is None:
            raise ValueError(f"{run.path}: min_gap_rotations needs the rotation period "
                             "(no rotation_period / omega in the file)")
        gap = self.min_gap_rotations * run.rotation_period
        chosen = [n - 1]
        # tolerance: snapshot times are multiples of a float interval
        tol = 1e-9 * max(1.0, abs(time[-1]))
        for i in range(n - 2, -1, -1):
            if len(chosen) == want or i < first:
                break
            if time[chosen[-1]] - time[i] >= gap - tol:
                chosen.append(i)
        return np.array(chosen[::-1], dtype=np.int64)

    def compute(self, run):
        diameter, length = self._check_run(run)
        fr = run.frames
        idx = self._select_frames(run)

        nx = max(1, int(round(diameter / self.cell)))
        ny = max(1, int(round(length / self.cell)))
        x_edges = np.linspace(-diameter / 2, diameter / 2, nx + 1)
        wx = x_edges[1] - x_edges[0]
        wy = length / ny
        x_centres = 0.5 * (x_edges[1:] + x_edges[:-1])

        n_species = max(len(fr.species_names), len(DEFAULT_SPECIES_NAMES),
                        int(fr.species.max()) + 1 if fr.species.size else 0)
        names = []
        for s in range(n_species):
            if s < len(fr.species_names) and fr.species_names[s]:
                names.append(str(fr.species_names[s]))
            elif s < len(DEFAULT_SPECIES_NAMES):
                names.append(DEFAULT_SPECIES_NAMES[s])
            else:
                names.append(f"species{s}")

        periodic = run.scene.get("drum", {}).get("ends") == "periodic"
        h_sum = np.zeros(nx)
        h_cnt = np.zeros(nx, dtype=np.int64)
        hs_sum = np.zeros((n_species, nx))
        hs_cnt = np.zeros((n_species, nx), dtype=np.int64)

        for f in idx:
            pos = fr.position[f]
            x, y = pos[:, 0], pos[:, 1]
            if periodic:  # an engine may store unwrapped coordinates
                y = (y + length / 2) % length - length / 2
            top = pos[:, 2] + fr.diameter[f] / 2
            ix = np.floor((x + diameter / 2) / wx).astype(np.int64)
            iy = np.floor((y + length / 2) / wy).astype(np.int64)
            # a centre exactly on the upper boundary belongs to the last cell
            ix[x == diameter / 2] = nx - 1
            iy[y == length / 2] = ny - 1
            ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & np.isfinite(top)
            if not ok.any():
                continue
            k = ix[ok] * ny + iy[ok]
            t = top[ok]
            sp = fr.species[f][ok]
            order = np.lexsort((t, k))       # by cell, then by top
            k, t, sp = k[order], t[order], sp[order]
            last = np.flatnonzero(np.r_[k[1:] != k[:-1], True])  # highest top per cell
            col = k[last] // ny
            h_sum += np.bincount(col, weights=t[last], minlength=nx)
            h_cnt += np.bincount(col, minlength=nx)
            for s in range(n_species):
                m = sp[last] == s
                hs_sum[s] += np.bincount(col[m], weights=t[last][m], minlength=nx)
                hs_cnt[s] += np.bincount(col[m], minlength=nx)

        with np.errstate(invalid="ignore", divide="ignore"):
            height = np.where(h_cnt > 0, h_sum / np.maximum(h_cnt, 1), np.nan)
            height_s = np.where(hs_cnt > 0, hs_sum / np.maximum(hs_cnt, 1), np.nan)

        # free-surface extent: columns below the upper wall by >= WALL_CLEARANCE
        wall = np.sqrt(np.maximum((diameter / 2) ** 2 - x_centres ** 2, 0.0))
        with np.errstate(invalid="ignore"):
            free = np.isfinite(height) & (height < wall - WALL_CLEARANCE)
        runs = _runs(free)
        if runs:
            centre = int(np.argmin(np.abs(x_centres)))
            containing = [r for r in runs if r[0] <= centre < r[1]]
            start, stop = containing[0] if containing else max(runs, key=lambda r: r[1] - r[0])
            extent = (float(x_centres[start] - wx / 2), float(x_centres[stop - 1] + wx / 2))
            mid = 0.5 * (extent[0] + extent[1])
            half = 0.5 * self.fit_window * (extent[1] - extent[0])
            fit_range = (mid - half, mid + half)
            in_win = (x_centres >= fit_range[0] - 1e-12) & (x_centres <= fit_range[1] + 1e-12)
        else:
            extent = (math.nan, math.nan)
            fit_range = (math.nan, math.nan)
            in_win = np.zeros(nx, dtype=bool)

        a, b, n_fit = _fit_line(x_centres[in_win], height[in_win])
        by_species_fit = {}
        for s, name in enumerate(names):
            a_s, b_s, n_s = _fit_line(x_centres[in_win], height_s[s][in_win])
            by_species_fit[name] = (a_s, b_s, n_s)

        period = run.rotation_period
        times = fr.time[idx]
        self._result = {
            "x": x_centres,
            "x_edges": x_edges,
            "height": height,
            "height_by_species": {n: height_s[s] for s, n in enumerate(names)},
            "counts": h_cnt,
            "counts_by_species": {n: hs_cnt[s] for s, n in enumerate(names)},
            "extent": extent,
            "fit_range": fit_range,
            "fit_points": n_fit,
            "intercept": a,
            "slope": b,
            "slope_angle_deg": _angle_deg(b),
            "slope_by_species": {n: v[1] for n, v in by_species_fit.items()},
            "intercept_by_species": {n: v[0] for n, v in by_species_fit.items()},
            "slope_angle_deg_by_species": {n: _angle_deg(v[1]) for n, v in by_species_fit.items()},
            "frames_used": times / period if period else times.copy(),
            "settled": bool(period is None or self.skip_rotations == 0 or self._past_skip(times[0], period)),
            "diameter": diameter,
            "length": length,
        }
        return self

    # -- results ---------------------------------------------------------------

    def _get(self, key):
        if self._result is None:
            raise RuntimeError("FreeSurface: call compute(run) before reading results")
        return self._result[key]

    @property
    def x(self):
        """(nx,) x-column centres."""
        return self._get("x")

    @property
    def x_edges(self):
        """(nx+1,) x-column edges, -D/2 .. D/2."""
        return self._get("x_edges")

    @property
    def height(self):
        """(nx,) mean surface height h(x), all species; NaN in empty columns."""
        return self._get("height")

    @property
    def height_by_species(self):
        """dict name -> (nx,) h_s(x) over cells whose surface particle is of species s."""
        return self._get("height_by_species")

    @property
    def counts(self):
        """(nx,) number of non-empty cells (over y-cells and frames) per column."""
        return self._get("counts")

    @property
    def counts_by_species(self):
        """dict name -> (nx,) number of cells per column whose surface particle is of that species."""
        return self._get("counts_by_species")

    @property
    def extent(self):
        """(x_lo, x_hi) of the free surface (outer cell edges); NaNs if none."""
        return self._get("extent")

    @property
    def fit_range(self):
        """(x_lo, x_hi) of the fit window; NaNs if there is no free surface."""
        return self._get("fit_range")

    @property
    def intercept(self):
        """a of the fit h = a + b x (all species)."""
        return self._get("intercept")

    @property
    def slope(self):
        """Signed slope b = dh/dx of the fit (all species); NaN if too few columns."""
        return self._get("slope")

    @property
    def slope_angle_deg(self):
        """degrees(atan(|slope|))."""
        return self._get("slope_angle_deg")

    @property
    def slope_by_species(self):
        """dict name -> signed slope of the fit to h_s(x) (NaN if < 3 columns)."""
        return self._get("slope_by_species")

    @property
    def slope_angle_deg_by_species(self):
        """dict name -> degrees(atan(|slope_s|)) (NaN if < 3 columns)."""
        return self._get("slope_angle_deg_by_species")

    @property
    def frames_used(self):
        """Times of the averaged snapshots, in rotations (ascending)."""
        return self._get("frames_used")

    @property
    def settled(self):
        """True when every averaged snapshot is past ``skip_rotations`` (or no
        skip applies); False when the run had none and the last one stood in."""
        return self._get("settled")

    def as_dict(self):
        """Main results as plain JSON-serialisable values (NaN -> None)."""
        r = self._get
        return _jsonable({
            "slope_angle_deg": r("slope_angle_deg"),
            "slope": r("slope"),
            "intercept": r("intercept"),
            "slope_angle_deg_by_species": r("slope_angle_deg_by_species"),
            "slope_by_species": r("slope_by_species"),
            "fit_range": list(r("fit_range")),
            "extent": list(r("extent")),
            "frames_used": r("frames_used"),
            "settled": r("settled"),
            "x": r("x"),
            "height": r("height"),
            "height_by_species": r("height_by_species"),
            "counts": r("counts"),
            "parameters": {"cell": self.cell, "frames": self.frames,
                           "fit_window": self.fit_window,
                           "min_gap_rotations": self.min_gap_rotations,
                           "skip_rotations": self.skip_rotations},
        })

    # -- plot ------------------------------------------------------------------

    def plot(self, ax=None):
        """Draw h_s(x) like Rapaport 2002 Fig. 9: small = small dark markers,
        big = larger light-grey markers with dark edge; the wall (dashed), the
        fit line over the fit window, equal aspect.  Returns ax."""
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(6, 5))
        x = self.x
        styles = {
            "small": dict(marker="o", ms=3.5, color="0.1", mec="0.1", ls="none"),
            "big": dict(marker="o", ms=7, color="0.8", mec="0.1", mew=0.8, ls="none"),
        }
        other = iter(["s", "^", "v", "D"])
        # big first so the small markers stay visible on top
        for name in sorted(self.height_by_species, key=lambda n: n != "big"):
            h = self.height_by_species[name]
            if not np.isfinite(h).any():
                continue
            st = styles.get(name, dict(marker=next(other, "x"), ms=5, ls="none"))
            ax.plot(x, h, label=name, **st)
        r = self._get("diameter") / 2
        phi = np.linspace(0, 2 * np.pi, 361)
        ax.plot(r * np.cos(phi), r * np.sin(phi), ls="--", color="0.4", lw=0.8, label="wall")
        lo, hi = self.fit_range
        if math.isfinite(self.slope) and math.isfinite(lo):
            xf = np.array([lo, hi])
            ax.plot(xf, self.intercept + self.slope * xf, color="tab:red", lw=1.5,
                    label=f"fit (slope {self.slope:+.3f})")
        ax.set_xlabel("x (across the drum)")
        ax.set_ylabel("surface height z")
        ax.set_aspect("equal")
        ax.set_xlim(-1.05 * r, 1.05 * r)
        ax.set_ylim(-1.05 * r, 1.05 * r)
        angle = self.slope_angle_deg
        ax.set_title(f"free surface: slope angle {angle:.1f}°" if math.isfinite(angle)
                     else "free surface: slope angle undetermined")
        ax.legend(loc="upper left", fontsize="small", frameon=False)
        return ax
