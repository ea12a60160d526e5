"""Band count and band formation time of a drum run (definitions and the
reasons for every threshold: docs/observables.md).

Both are measured against a random mixture of the same particles: the
particles of a snapshot keep their positions and the (species, diameter)
pairs are shuffled among them, which gives a profile with the same slice
occupancy and only the noise of a random assignment.
"""
import numpy as np
from scipy.ndimage import gaussian_filter1d

from ._common import Result
from .profile import drum_length, wrapped_y
from .spacetime import SpaceTime, axial_profile


def _periodic(run):
    return run.scene.get("drum", {}).get("ends") == "periodic"


def mean_small_fraction(run, frame=-1):
    """Volume-weighted small fraction of the whole drum (constant in a run)."""
    w = run.frames.diameter[frame] ** 3
    return float(w[run.frames.species[frame] == 0].sum() / w.sum())


def deviation(row, mean):
    """Profile minus the mean, empty (NaN) slices counted as average."""
    d = np.asarray(row, dtype=np.float64) - mean
    return np.where(np.isnan(d), 0.0, d)


def slice_weights(run, edges):
    """Mean particle volume (sum of d^3) per slice over all snapshots: the
    weight of each slice's concentration. Slices near a cap hold fewer
    particles and their concentration is correspondingly noisier."""
    w = np.zeros(len(edges) - 1)
    for f in range(run.frames.n_frames):
        w += np.histogram(wrapped_y(run, f), bins=edges, weights=run.frames.diameter[f] ** 3)[0]
    w /= max(1, run.frames.n_frames)
    return w / w.mean() if w.mean() > 0 else np.ones_like(w)


def smooth(dev, sigma, periodic, weights=None):
    """Gaussian smoothing along the axis as a normalised convolution,
    sum(G w dev) / sum(G w): a sparsely filled slice counts for little, and
    nothing is assumed beyond a cap. Periodic ends wrap around."""
    dev = np.asarray(dev, dtype=np.float64)
    if sigma <= 0:
        return dev
    w = np.ones_like(dev) if weights is None else np.asarray(weights, dtype=np.float64)
    mode = "wrap" if periodic else "constant"
    num = gaussian_filter1d(w * dev, sigma, mode=mode)
    den = gaussian_filter1d(w, sigma, mode=mode)
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def mode_amplitude(dev, min_modes=1, max_mode=None):
    """Largest |Fourier coefficient| of the deviation over modes min_modes..max_mode
    (mode k has k wavelengths along the drum), and that k."""
    c = np.abs(np.fft.rfft(dev)) / len(dev)
    hi = len(c) - 1 if max_mode is None else min(max_mode, len(c) - 1)
    k = min_modes + int(np.argmax(c[min_modes:hi + 1]))
    return float(c[k]), k


def count_bands(smoothed, threshold, min_width, periodic):
    """Number of bands in a smoothed profile deviation.

    Slices above +threshold are small-rich, below -threshold big-rich, the rest
    undecided. A band is a run of at least ``min_width`` consecutive decided
    slices of one sign; runs of the same sign separated only by undecided
    slices or by shorter runs are one band. With periodic ends the profile is
    a ring: the first and last bands merge if they have the same sign, and a
    lone band implies its complement, so the count is even.
    """
    s = np.where(smoothed > threshold, 1, np.where(smoothed < -threshold, -1, 0))
    n = len(s)
    if periodic and np.all(s == s[0]):
        return 0 if s[0] == 0 else 1
    # Runs of equal sign; for a ring, start at a boundary between runs.
    start = 0
    if periodic:
        start = int(np.argmax(s != np.roll(s, 1)))
    seq = np.roll(s, -start) if periodic else s
    signs = []
    k = 0
    while k < n:
        j = k
        while j < n and seq[j] == seq[k]:
            j += 1
        if seq[k] != 0 and j - k >= min_width:
            signs.append(int(seq[k]))
        k = j
    merged = [x for i, x in enumerate(signs) if i == 0 or x != signs[i - 1]]
    if periodic and len(merged) > 1 and merged[0] == merged[-1]:
        merged.pop()
    count = len(merged)
    if periodic and count == 1:
        count = 2
    return count


class RandomMixture:
    """Noise of a random mixture: per-slice standard deviation of the smoothed
    profile deviation, and the mean largest Fourier-mode amplitude."""

    def __init__(self, shuffles=32, seed=0):
        self.shuffles = int(shuffles)
        self.seed = int(seed)

    def compute(self, run, edges, sigma, min_modes=1, max_mode=None, frame=-1, weights=None):
        rng = np.random.default_rng(self.seed)
        y = wrapped_y(run, frame)
        d = run.frames.diameter[frame]
        sp = run.frames.species[frame]
        periodic = _periodic(run)
        sm, amps = [], []
        for _ in range(self.shuffles):
            perm = rng.permutation(len(y))
            row = axial_profile(y, d[perm], sp[perm], edges)
            mean = float((d[perm] ** 3)[sp[perm] == 0].sum() / (d ** 3).sum())
            dev = deviation(row, mean)
            sm.append(smooth(dev, sigma, periodic, weights))
            w = 1.0 if weights is None else weights
            amps.append(mode_amplitude(w * dev, min_modes, max_mode)[0])
        self.noise_sigma = float(np.std(np.concatenate(sm)))
        self.mode_amplitude = float(np.mean(amps))
        return self


def _profile(run):
    st = SpaceTime().compute(run)
    return st.time_rotations, st.y_edges, st.small_fraction


class BandCount(Result):
    """Number of bands at every profile sample.

    smoothing: Gaussian sigma in slices; threshold: in units of the random
    mixture's noise sigma; min_width: slices. ``early`` is the most common count
    over ``early_window`` rotations after ``start`` (the formation time if given
    to compute, else the start of the run); ``final`` the most common count over
    the last ``final_window`` rotations.
    """

    def __init__(self, smoothing=2.0, threshold=4.0, min_width=3, early_window=20.0, final_window=20.0,
                 shuffles=32, seed=0):
        self.smoothing, self.threshold, self.min_width = float(smoothing), float(threshold), int(min_width)
        self.early_window, self.final_window = float(early_window), float(final_window)
        self.mixture = RandomMixture(shuffles, seed)
        self._result = None

    def compute(self, run, start=None):
        t, edges, frac = _profile(run)
        periodic = _periodic(run)
        mean = mean_small_fraction(run)
        w = slice_weights(run, edges)
        noise = self.mixture.compute(run, edges, self.smoothing, weights=w).noise_sigma
        thr = self.threshold * noise
        counts = np.array([count_bands(smooth(deviation(r, mean), self.smoothing, periodic, w), thr, self.min_width,
                                       periodic) for r in frac], dtype=int)

        def mode_in(lo, hi):
            sel = counts[(t >= lo) & (t <= hi)]
            return int(np.bincount(sel).argmax()) if sel.size else None

        t0 = float(t[0]) if start is None else float(start)
        self._result = {"time_rotations": t, "counts": counts, "noise_sigma": noise, "threshold_abs": thr,
                   "mean": mean, "periodic": periodic,
                   "early": mode_in(t0, t0 + self.early_window) if t.size else None,
                   "final": mode_in(t[-1] - self.final_window, t[-1]) if t.size else None,
                   "early_start": t0}
        return self

    time_rotations = property(lambda self: self._get("time_rotations"))
    counts = property(lambda self: self._get("counts"))
    noise_sigma = property(lambda self: self._get("noise_sigma"))
    threshold_abs = property(lambda self: self._get("threshold_abs"))
    early = property(lambda self: self._get("early"))
    final = property(lambda self: self._get("final"))

    def at(self, rotations):
        """Band count at the sample nearest to the given time (rotations)."""
        k = int(np.argmin(np.abs(self.time_rotations - rotations)))
        return int(self.counts[k])

    def as_dict(self):
        return {"early": self.early, "early_from_rotation": self._get("early_start"), "final": self.final,
                "noise_sigma": self.noise_sigma, "threshold": self.threshold_abs,
                "parameters": {"smoothing_slices": self.smoothing, "threshold_sigmas": self.threshold,
                               "min_width_slices": self.min_width, "early_window": self.early_window,
                               "final_window": self.final_window}}

    def plot(self, ax=None):
        import matplotlib.pyplot as plt
        ax = ax or plt.gca()
        ax.step(self.time_rotations, self.counts, where="post", color="k", lw=1)
        ax.set_xlabel("rotations")
        ax.set_ylabel("band count")
        ax.set_ylim(bottom=0)
        return ax


class BandFormation(Result):
    """Band formation time from a segregation order parameter.

    R(t) = largest Fourier amplitude of the profile deviation over modes with
    wavelength >= min_wavelength (length units), divided by the same quantity
    for a random mixture. R is averaged over a centred window of
    ``window`` rotations; the formation time is the first sample from which the
    averaged R stays >= ``threshold`` to the end of the run (None if never).
    """

    def __init__(self, threshold=3.0, window=5.0, min_wavelength=8.0, shuffles=32, seed=0):
        self.threshold, self.window, self.min_wavelength = float(threshold), float(window), float(min_wavelength)
        self.mixture = RandomMixture(shuffles, seed)
        self._result = None

    def compute(self, run):
        t, edges, frac = _profile(run)
        length = drum_length(run)
        max_mode = max(1, int(length // self.min_wavelength))
        mean = mean_small_fraction(run)
        w = slice_weights(run, edges)
        ref = self.mixture.compute(run, edges, 0.0, 1, max_mode, weights=w).mode_amplitude
        amp, modes = [], []
        for r in frac:
            a, k = mode_amplitude(w * deviation(r, mean), 1, max_mode)
            amp.append(a)
            modes.append(k)
        order = np.array(amp) / ref
        smoothed = order.copy()
        if t.size > 1 and self.window > 0:
            cs = np.concatenate([[0.0], np.cumsum(order)])
            lo = np.searchsorted(t, t - self.window / 2, side="left")
            hi = np.searchsorted(t, t + self.window / 2, side="right")
            smoothed = (cs[hi] - cs[lo]) / (hi - lo)
        above = smoothed >= self.threshold
        formation = None
        if above.size and above[-1]:
            below = np.nonzero(~above)[0]
            first = 0 if below.size == 0 else below[-1] + 1
            formation = float(t[first])
        self._result = {"time_rotations": t, "order": order, "smoothed": smoothed, "formation": formation,
                   "modes": np.array(modes), "reference": ref, "max_mode": max_mode}
        return self

    time_rotations = property(lambda self: self._get("time_rotations"))
    order_parameter = property(lambda self: self._get("order"))
    smoothed = property(lambda self: self._get("smoothed"))
    formation_time = property(lambda self: self._get("formation"))
    dominant_mode = property(lambda self: self._get("modes"))

    def as_dict(self):
        o = self.smoothed
        return {"formation_time_rotations": self.formation_time,
                "order_parameter_final": float(o[-1]) if o.size else None,
                "order_parameter_max": float(o.max()) if o.size else None,
                "dominant_mode_final": int(self.dominant_mode[-1]) if o.size else None,
                "random_mixture_amplitude": self._get("reference"),
                "parameters": {"threshold": self.threshold, "window_rotations": self.window,
                               "min_wavelength": self.min_wavelength, "max_mode": self._get("max_mode")}}

    def plot(self, ax=None):
        import matplotlib.pyplot as plt
        ax = ax or plt.gca()
        ax.plot(self.time_rotations, self.order_parameter, color="0.7", lw=0.6, label="R(t)")
        ax.plot(self.time_rotations, self.smoothed, color="k", lw=1.2, label=f"R, {self.window:g}-rotation mean")
        ax.axhline(self.threshold, color="tab:red", ls="--", lw=1, label=f"threshold {self.threshold:g}")
        if self.formation_time is not None:
            ax.axvline(self.formation_time, color="tab:blue", lw=1, label=f"formed at {self.formation_time:.1f}")
        ax.set_xlabel("rotations")
        ax.set_ylabel("segregation order parameter R")
        ax.legend(fontsize="small")
        return ax


def lasting_count(t, counts, window):
    """The band count that lasts: the most common count in a centred window of
    ``window`` rotations around each sample (a count that flickers for a few
    samples, as a band crosses the detection threshold, does not move it)."""
    t, counts = np.asarray(t, float), np.asarray(counts, int)
    lo = np.searchsorted(t, t - 0.5 * window, side="left")
    hi = np.searchsorted(t, t + 0.5 * window, side="right")
    width = int(counts.max()) + 1 if counts.size else 1
    return np.array([np.bincount(counts[a:b], minlength=width).argmax() for a, b in zip(lo, hi)], dtype=int)


def band_events(t, counts, window=50.0):
    """Merging and splitting events: changes of the lasting count (above) whose
    new value holds for at least ``window`` rotations. Returns a list of
    {"rotation", "from", "to", "kind"} with kind "merge" (fewer bands), "split"
    (more), "formation" (from none) or "mixing" (to none), at the first sample
    of the new value."""
    t = np.asarray(t, float)
    if t.size == 0:
        return []
    lasting = lasting_count(t, counts, window)
    # runs of equal lasting count: (start index, end index exclusive, value)
    cut = np.nonzero(np.diff(lasting))[0] + 1
    starts, ends = np.concatenate([[0], cut]), np.concatenate([cut, [t.size]])
    runs = [(s, e, int(lasting[s])) for s, e in zip(starts, ends)]
    # a run shorter than the window is a passing state: it extends the state before it
    kept = []
    for s, e, v in runs:
        duration = (t[e] if e < t.size else t[-1]) - t[s]
        if kept and (v == kept[-1][2] or duration < window):
            kept[-1] = (kept[-1][0], e, kept[-1][2])
        else:
            kept.append((s, e, v))
    events = []
    for (_, _, a), (s, _, b) in zip(kept, kept[1:]):
        if a != b:
            kind = "formation" if a == 0 else "mixing" if b == 0 else "merge" if b < a else "split"
            events.append({"rotation": float(t[s]), "from": a, "to": b, "kind": kind})
    return events
