"""Section V of Rapaport (2002): the qualitative claims about long runs, each
as a number computed from the axial profile (docs/observables.md, "Long runs").

- interface width over time (#V, #X: "no hint of mixing");
- mixing time (#W: "the initial bands rapidly vanish as the species mix");
- the exchange of the segregated regions (#Y: "the segregated regions can be
  seen to have exchanged positions relative to the initial state");
- the band speed (#Y: "approximately 1 % of the small particle diameter per
  revolution" in the central portion of the run);
- the species at the caps (capped runs: "it is the big particles ... that
  occupy the end bands"; odd band counts);
- the band contrast (#P, #Q: fuller drums segregate less thoroughly);
- where band formation starts (capped runs: "band formation begins almost
  simultaneously at several distinct locations, the ends do not function as
  nucleation sites");
- the wandering of a periodic pattern as a whole (#A, Fig. 1: "apparently
  random oscillatory motion in the axial direction, although the
  fluctuations tend to be less than the spacing between alternate bands").

All take the profile as (t, y_centres, phi): rotations, slice centres and the
small-particle volume fraction per slice (NaN where empty), with the drum's
overall small fraction ``mean``.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy.ndimage import gaussian_filter1d

PURE = 0.1  # a slice within 0.1 of a pure species (phi < 0.1 or > 0.9) is segregated


def _filled(row, mean):
    row = np.asarray(row, dtype=np.float64)
    return np.where(np.isnan(row), mean, row)


def interface_width(phi, dy, n_interfaces):
    """Axial width of the mixed zone per interface: the length of the slices
    neither nearly pure small (> 1 - PURE) nor nearly pure big (< PURE),
    divided by the number of interfaces. A sharply segregated profile gives
    about one slice; a mixed drum gives L / n_interfaces."""
    phi = np.asarray(phi, dtype=np.float64)
    mixed = (phi > PURE) & (phi < 1.0 - PURE)
    return float(mixed.sum(axis=-1) * dy / max(1, n_interfaces)) if phi.ndim == 1 else \
        mixed.sum(axis=-1) * dy / max(1, n_interfaces)


def lasting_below(t, x, level):
    """First time from which x stays below level to the end (None if it does not)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    if x.size == 0 or x[-1] >= level:
        return None
    above = np.nonzero(x >= level)[0]
    return float(t[0] if above.size == 0 else t[above[-1] + 1])


def exchange(phi, mean, smoothing=2.0, periodic=False):
    """Correlation of each profile with the first one (smoothed deviations
    from the mean): +1 as it started, -1 with the segregated regions
    exchanged, near 0 mixed or shifted by a quarter wavelength."""
    mode = "wrap" if periodic else "nearest"
    dev = gaussian_filter1d(np.nan_to_num(np.asarray(phi, float) - mean), smoothing, axis=-1, mode=mode)
    d0 = dev[0]
    norm = np.sqrt((dev ** 2).sum(axis=-1) * (d0 ** 2).sum())
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0, (dev * d0).sum(axis=-1) / norm, 0.0)


def interfaces(row, y, mean, smoothing=2.0):
    """Axial positions where the smoothed profile crosses the mean (linear
    interpolation between slice centres)."""
    dev = gaussian_filter1d(_filled(row, mean) - mean, smoothing, mode="nearest")
    k = np.nonzero(np.sign(dev[:-1]) * np.sign(dev[1:]) < 0)[0]
    return y[k] + (y[k + 1] - y[k]) * dev[k] / (dev[k] - dev[k + 1])


def band_speed(t, y, phi, mean, window=1000.0, smoothing=2.0, central=(0.25, 0.75)):
    """Speed of the band boundaries, in length units (small diameters) per
    rotation: every boundary present at both ends of a window of ``window``
    rotations within the central part of the run (fractions of its length)
    is followed (nearest crossing in each profile, one slice at most per
    sample) and fitted with a straight line; returns the median |slope| and
    the slopes. None if no boundary could be followed."""
    t = np.asarray(t, float)
    lo_t, hi_t = t[0] + central[0] * (t[-1] - t[0]), t[0] + central[1] * (t[-1] - t[0])
    dy = float(y[1] - y[0])
    slopes = []
    start = lo_t
    while start + window <= hi_t:
        sel = np.nonzero((t >= start) & (t < start + window))[0]
        start += window
        if sel.size < 10:
            continue
        for y0 in interfaces(phi[sel[0]], y, mean, smoothing):
            track, times, cur = [], [], y0
            for k in sel:
                c = interfaces(phi[k], y, mean, smoothing)
                if c.size == 0:
                    break
                j = int(np.argmin(np.abs(c - cur)))
                if abs(c[j] - cur) > 2.0 * dy:  # lost it (merged, or another boundary)
                    break
                cur = c[j]
                track.append(cur)
                times.append(t[k])
            if len(track) == sel.size:
                slopes.append(np.polyfit(times, track, 1)[0])
    if not slopes:
        return None, []
    return float(np.median(np.abs(slopes))), [float(s) for s in slopes]


def end_species(row, mean, n_slices=4):
    """Which species fills each end of a capped drum: "big" when the mean
    small fraction of the ``n_slices`` slices next to the cap is below the
    drum's, else "small". Returns (left, right). The slice against the cap is
    left out: only centres of grains that fit that close to the flat cap lie
    in it, mostly small ones, whatever band is there."""
    row = _filled(row, mean)
    ends = (row[1:1 + n_slices], row[-1 - n_slices:-1])
    return tuple("big" if np.nanmean(part) < mean else "small" for part in ends)


def contrast(phi, mean, smoothing=2.0, periodic=True):
    """Band contrast: the standard deviation along the axis of the smoothed
    small fraction (0 for a mixed drum, about 0.5 for pure alternating bands)."""
    mode = "wrap" if periodic else "nearest"
    dev = gaussian_filter1d(np.nan_to_num(np.asarray(phi, float) - mean), smoothing, axis=-1, mode=mode)
    return dev.std(axis=-1)


ONSET_LEVEL = 0.2  # |smoothed deviation| of the small fraction that marks a band as begun


def band_onsets(t, y, phi, mean, t_ref, level=ONSET_LEVEL, smoothing=2.0, time_smoothing=1.0, periodic=False):
    """When each band began: the bands are the runs of one sign of the
    smoothed deviation from ``mean`` at the profile nearest ``t_ref``
    (rotations); a band's onset is the first time |deviation| exceeds
    ``level`` in any of its slices. The deviation is smoothed by ``smoothing``
    slices along the axis and ``time_smoothing`` rotations in time. With caps,
    the slice against each cap is left out (mostly small grains whatever the
    band, see end_species). Returns one dict a band, in axial order: y_lo,
    y_hi (slice centres), species ("small" or "big"), end (touches a cap),
    onset (rotations; None if not by the end of the run). With periodic ends
    a band that wraps across the boundary is one band, listed first, its
    y_lo above its y_hi."""
    t = np.asarray(t, float)
    raw = np.nan_to_num(np.asarray(phi, float) - mean)
    if not periodic:
        raw[:, 0] = raw[:, -1] = 0.0
    dev = gaussian_filter1d(raw, smoothing, axis=1, mode="wrap" if periodic else "nearest")
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    if time_smoothing > 0 and t.size > 1:
        dev = gaussian_filter1d(dev, time_smoothing / dt, axis=0, mode="nearest")
    ref = dev[int(np.argmin(np.abs(t - t_ref)))]
    sign = np.sign(ref)
    cuts = np.nonzero(sign[1:] != sign[:-1])[0] + 1
    over = np.abs(dev) > level
    segs = np.split(np.arange(ref.size), cuts)
    if periodic and len(segs) > 1 and sign[0] == sign[-1]:  # one band across the periodic boundary
        segs = [np.concatenate([segs[-1], segs[0]])] + segs[1:-1]
    out = []
    for seg in segs:
        hit = over[:, seg].any(axis=1)
        out.append({"y_lo": float(y[seg[0]]), "y_hi": float(y[seg[-1]]),
                    "species": "small" if sign[seg[0]] > 0 else "big",
                    "end": (not periodic) and (seg[0] == 0 or seg[-1] == ref.size - 1),
                    "onset": float(t[np.argmax(hit)]) if hit.any() else None})
    return out


def pattern_excursion(t, phi, mean, length, min_rotations=200.0):
    """How far a periodic band pattern wanders as a whole. The pattern's
    position is the phase of its dominant axial Fourier mode k (of the
    deviation from ``mean``), x = -arg(F_k) L / (2 pi k), unwrapped in time,
    followed over the last stretch of the run in which k stays the same (a
    merge or split changes k and ends the pattern being followed). Returns
    (excursion, wavelength L / k, rotations followed): the range of x over
    that stretch, the spacing between alternate bands, and the stretch's
    length; None if the stretch is shorter than ``min_rotations``."""
    t = np.asarray(t, float)
    dev = np.nan_to_num(np.asarray(phi, float) - mean)
    f = np.fft.rfft(dev, axis=-1)
    k = np.argmax(np.abs(f[:, 1:]), axis=1) + 1
    other = np.nonzero(k != k[-1])[0]
    start = other[-1] + 1 if other.size else 0
    if t[-1] - t[start] < min_rotations:
        return None
    kk = int(k[-1])
    x = -np.unwrap(np.angle(f[start:, kk])) * length / (2 * np.pi * kk)
    return float(x.max() - x.min()), float(length / kk), float(t[-1] - t[start])


def section_v(run, obs):
    """The claims' numbers for one run (JSON-ready)."""
    st = obs["spacetime"]
    t, edges, phi = st.time_rotations, st.y_edges, st.small_fraction
    y = 0.5 * (edges[1:] + edges[:-1])
    dy = float(edges[1] - edges[0])
    from .bands import mean_small_fraction
    mean = mean_small_fraction(run)
    periodic = run.scene["drum"]["ends"] == "periodic"
    sc = run.scene
    out = {}
    n_bands = max(1, obs["bands"].final or 1)
    n_if = n_bands if periodic else max(1, n_bands - 1)
    width = interface_width(phi, dy, n_if)
    c = contrast(phi, mean, periodic=periodic)
    last = t >= t[-1] - 0.1 * (t[-1] - t[0])
    first = t <= t[0] + 0.1 * (t[-1] - t[0])
    out["interface_width_first_tenth"] = float(np.mean(width[first]))
    out["interface_width_last_tenth"] = float(np.mean(width[last]))
    out["contrast_last_tenth"] = float(np.mean(c[last]))
    if sc["particles"]["initial_state"] != "mixed":
        ex = exchange(phi, mean, periodic=periodic)
        out["exchange_min"] = float(ex.min())
        out["exchanged_at"] = float(t[np.argmax(ex < -0.5)]) if (ex < -0.5).any() else None
        order = obs["formation"].smoothed
        out["mixing_time"] = lasting_below(obs["formation"].time_rotations, order, obs["formation"].threshold)
    if periodic:
        pe = pattern_excursion(t, phi, mean, float(sc["drum"]["length"]))
        if pe is not None:
            out["pattern_excursion"], out["pattern_wavelength"], out["pattern_rotations"] = pe
    if not periodic and obs["formation"].formation_time is not None:
        # the bands as they stand 30 rotations after formation, before later merging
        t_ref = min(float(t[-1]), obs["formation"].formation_time + 30.0)
        on = band_onsets(t, y, phi, mean, t_ref)
        out["onset_interior"] = sorted(b["onset"] for b in on if not b["end"] and b["onset"] is not None)
        out["onset_interior_bands"] = len([b for b in on if not b["end"]])
        out["onset_ends"] = [b["onset"] for b in on if b["end"]]
    if not periodic:
        with warnings.catch_warnings():  # a slice empty in every row stays NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            out["ends_last_tenth"] = end_species(np.nanmean(phi[last], axis=0), mean)
        out["band_count_odd"] = bool((obs["bands"].final or 0) % 2 == 1)
    speed, slopes = band_speed(t, y, phi, mean)
    out["band_speed_median"] = speed
    out["band_speed_tracks"] = len(slopes)
    return out


# ---------------------------------------------------------------------------
# Verdicts on the claims. Each function takes the measures above and returns
# (verdict, reason) with verdict "agree", "disagree" or "inconclusive". The
# margins are fixed here, from the paper's words and from the spread of the
# measures between runs that the paper calls alike, not from the runs judged.

# Sharp interfaces: over the last tenth of the full-length runs the segregated
# #A (periodic, mixed start) and #X (capped, segregated start) measure 10.2 and
# 12.8 small diameters, a spread of 25 %; the paper calls both sharp. A width
# that grows by no more than that is "no hint of mixing"; one that grows by
# more than half has blurred as much as #P's edges (1.7 times #A's), which the
# paper calls "starting to blur". Between the two: inconclusive.
SHARP_SPREAD = 0.25
BLUR_GROWTH = 0.50
# #Y's exchange: the correlation of the profile with the starting one reaches
# -1 for a full exchange; below -0.5 (the ``exchanged_at`` mark) more than half
# the drum has swapped, which a space-time plot shows as an exchange. A run
# whose correlation never falls below -0.25 has at no time swapped even a
# quarter of it.
EXCHANGED, NOT_EXCHANGED = -0.5, -0.25
# #Y's band speed: the paper's "approximately 1 %" per revolution is one
# segment's gradient read off Fig. 16, so a factor of 3 either way agrees.
PAPER_BAND_SPEED, SPEED_FACTOR = 0.01, 3.0
# A pattern held by caps is "completely stationary" (#X): its boundaries move
# less than a tenth of #Y's speed, under 5.4 small diameters over #X's 5400
# rotations, half a sharp interface.
STILL_SPEED = 0.001
# #Q's contrast against #P's: a mixed drum measures 0.02 (#F-#H), so a fall
# of 0.05 is beyond that floor; the formation time must at least double.
CONTRAST_DROP, SLOWER_FORMATION = 0.05, 2.0


def boundaries_text(n):
    """"1 boundary", "3 boundaries": how many boundaries a band speed followed."""
    return f"{n} boundary" if n == 1 else f"{n} boundaries"


def combine(parts):
    """One verdict from several: disagree if any part disagrees, else
    inconclusive if any part is, else agree. ``parts`` are (verdict, reason)."""
    verdicts = [v for v, _ in parts]
    v = "disagree" if "disagree" in verdicts else "inconclusive" if "inconclusive" in verdicts else "agree"
    return v, "; ".join(r for _, r in parts)


def no_mixing_verdict(v):
    """#V, #X: "no hint of mixing"."""
    if v.get("mixing_time") is not None:
        return "disagree", f"the order parameter stays below the mixing threshold from rotation {v['mixing_time']:.0f}"
    w0, w1 = v["interface_width_first_tenth"], v["interface_width_last_tenth"]
    growth = w1 / w0 - 1.0 if w0 > 0 else float("inf")
    text = f"interface width {growth:+.0%} from the first to the last tenth"
    if growth <= SHARP_SPREAD:
        return "agree", f"{text}, within the {SHARP_SPREAD:.0%} spread of sharp interfaces"
    if growth > BLUR_GROWTH:
        return "disagree", f"{text}, beyond {BLUR_GROWTH:.0%}: the interfaces have blurred"
    return "inconclusive", f"{text}, between {SHARP_SPREAD:.0%} and {BLUR_GROWTH:.0%}"


def mixing_verdict(v):
    """#W: "the initial bands rapidly vanish as the species mix" (the paper
    gives no time; the bands must vanish within its run)."""
    if v.get("mixing_time") is None:
        return "disagree", "the bands are still there at the end of the run"
    return "agree", f"mixed from rotation {v['mixing_time']:.0f}"


def events_verdict(events):
    """#Y: "multiple band formation and disappearance events"."""
    splits = sum(1 for e in events if e["to"] > e["from"] > 0)
    merges = sum(1 for e in events if 0 < e["to"] < e["from"])
    text = f"{splits} splits and {merges} merges"
    if splits and merges and splits + merges >= 2:
        return "agree", text
    return "disagree", text


def exchange_verdict(v):
    """#Y: the segregated regions exchange positions at one point of the run."""
    m = v.get("exchange_min")
    if m is None:
        return "inconclusive", "no exchange measure"
    text = f"correlation with the start reaches {m:.2f}"
    if m <= EXCHANGED:
        return "agree", text
    if m > NOT_EXCHANGED:
        return "disagree", f"{text}, never below {NOT_EXCHANGED}"
    return "inconclusive", f"{text}, between {EXCHANGED} and {NOT_EXCHANGED}"


def band_speed_verdict(v):
    """#Y: band speed about 1 % of the small diameter per revolution."""
    s, n = v.get("band_speed_median"), v.get("band_speed_tracks", 0)
    if s is None or n == 0:
        return "inconclusive", "no boundary could be followed"
    text = f"band speed {s:.2g} d per rotation ({boundaries_text(n)})"
    lo, hi = PAPER_BAND_SPEED / SPEED_FACTOR, PAPER_BAND_SPEED * SPEED_FACTOR
    if lo <= s <= hi:
        return "agree", text
    return "disagree", f"{text}, outside {lo:.2g}-{hi:.2g}"


def capped_ends_verdict(bands_final, ends):
    """Capped runs started mixed: an odd band count, the big particles at both ends."""
    odd = bands_final is not None and bands_final % 2 == 1
    text = f"{bands_final} bands, ends {'/'.join(ends)}"
    return ("agree" if odd and tuple(ends) == ("big", "big") else "disagree"), text


def nucleation_verdict(v):
    """Capped runs: formation begins at several interior places, not at the ends."""
    interior = v.get("onset_interior") or []
    ends = [e for e in v.get("onset_ends", []) if e is not None]
    first_end = min(ends) if ends else float("inf")
    before = sum(1 for x in interior if x < first_end)
    text = f"{before} interior bands begin before the first end band"
    return ("agree" if before >= 2 else "disagree"), text


def wander_verdict(v, capped):
    """A periodic pattern wanders by less than the spacing between alternate
    bands (#A, Fig. 1); a capped one stays still (#X)."""
    if capped:
        s = v.get("band_speed_median")
        if s is None:
            return "inconclusive", "no boundary could be followed"
        return ("agree" if s <= STILL_SPEED else "disagree"), f"band speed {s:.2g} d per rotation"
    if v.get("pattern_excursion") is None:
        return "inconclusive", "no stretch of 200 rotations with one dominant mode"
    ratio = v["pattern_excursion"] / v["pattern_wavelength"]
    return ("agree" if ratio < 1.0 else "disagree"), f"{ratio:.2f} of the alternate-band spacing"


def wander_many_verdict(ratios):
    """One periodic scene over several runs, each excursion as a fraction of
    the alternate-band spacing: the paper's "the fluctuations tend to be less
    than the spacing" agrees when every run stays under one spacing and
    disagrees when the median does not."""
    r = np.asarray(ratios, float)
    text = f"{r.min():.2f}-{r.max():.2f} of the alternate-band spacing, median {np.median(r):.2f}"
    if r.max() < 1.0:
        return "agree", text
    if np.median(r) >= 1.0:
        return "disagree", text
    return "inconclusive", text


def blur_verdict(a, p, q):
    """#P: "the band edges are starting to blur" (wider interfaces than #A);
    #Q: less thorough segregation than #P (contrast) and bands that take
    longer to appear. ``a``, ``p``, ``q``: (section_v measures, formation
    rotation or None)."""
    (va, fa), (vp, fp), (vq, fq) = a, p, q
    ratio = vp["interface_width_last_tenth"] / va["interface_width_last_tenth"]
    width = (("agree" if ratio >= 1 + SHARP_SPREAD else "disagree" if ratio <= 1.0 else "inconclusive"),
             f"#P's interfaces {ratio:.2f} times #A's")
    drop = vp["contrast_last_tenth"] - vq["contrast_last_tenth"]
    con = (("agree" if drop >= CONTRAST_DROP else "disagree" if drop <= 0 else "inconclusive"),
           f"#Q's contrast {drop:.3f} below #P's")
    if fq is None:
        form = ("disagree", "#Q formed no bands")
    else:
        ref = max(x for x in (fa, fp, 0.0) if x is not None)
        form = (("agree" if fq >= SLOWER_FORMATION * ref else "disagree" if fq <= ref else "inconclusive"),
                f"#Q's bands form at rotation {fq:.0f}, against {ref:.0f}")
    return combine([width, con, form])
