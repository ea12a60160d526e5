"""The shaken box's figures over a set of runs: the paper's Fig. 1 (drift
field), Fig. 3 (Phi(D) with and without the big disk), Fig. 4 (the big disk's
height), the force ratio around the big disk, and the convection onset from a
slow frequency ramp up and down (hysteresis).

    python3 -m compare box-report --big RUN.h5... --nobig RUN.h5... \
        [--ramp RUN.h5...] [--height RUN.h5...] -o DIR

Every number comes from the observables of :mod:`compare.box`; this module
only groups runs (by shaking frequency) and draws. ``box_report.json`` in DIR
holds every number shown.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ._common import clean_json
from .box import BigDiskHeight, ConvectiveFlux, ForceRatio, Shaker, VelocityField, _big_column, top_motion
from .reader import read_run


def _freq(run) -> float:
    return round(Shaker(run).f0, 6)


def _label(path) -> str:
    return Path(path).stem


# --------------------------------------------------------------------------- Fig. 3 and the force ratio

def flux_by_frequency(big_paths, nobig_paths, skip_cycles=5, periods=50):
    """Phi(D) of every run, grouped by frequency: {f: {"big": [...], "nobig": [...]}},
    over the last ``periods`` cycles of shaking (the paper's Fig. 3 averages
    over 50; None: every cycle after ``skip_cycles``).
    The line heights are fractions of each run's own settled bed height, so
    runs are averaged on D / H."""
    groups = {}
    for kind, paths in (("big", big_paths), ("nobig", nobig_paths)):
        for p in paths:
            run = read_run(p)
            skip = skip_cycles
            if periods:
                total = int(Shaker(run).cycles(run.frames.time[-1]))
                skip = max(skip_cycles, total - periods)
            cf = ConvectiveFlux(skip_cycles=skip, max_cycles=periods).compute(run)
            groups.setdefault(_freq(run), {"big": [], "nobig": []})[kind].append(
                {"run": _label(p), "heights": cf.heights, "bed_height": cf.bed_height, "phi": cf.phi,
                 "phi_se": cf.phi_se, "phi_max": cf.phi_max, "depth": cf.depth, "cycles": cf.cycles_used,
                 "phi_depth_mean": float(np.nanmean(cf.phi))})
    return dict(sorted(groups.items()))


def plot_flux(groups, path):
    freqs = list(groups)
    fig = Figure(figsize=(3.2 * max(1, len(freqs)), 5.5), layout="constrained")
    axes = fig.subplots(1, max(1, len(freqs)), sharey=True, squeeze=False)[0]
    for ax, f in zip(axes, freqs):
        for kind, colour in (("nobig", "tab:blue"), ("big", "tab:red")):
            rows = groups[f][kind]
            if not rows:
                continue
            # on the common grid D/H, one curve per run, then the mean
            x = np.array([r["phi"] for r in rows])
            z = rows[0]["heights"] / rows[0]["bed_height"]
            for r in rows:
                ax.plot(r["phi"], r["heights"] / r["bed_height"], color=colour, lw=0.5, alpha=0.35)
            ax.plot(np.nanmean(x, axis=0), z, color=colour, lw=1.8,
                    label=f"{'with' if kind == 'big' else 'without'} big disk ({len(rows)})")
        ax.axvline(0.0, color="0.4", lw=0.6)
        cycles = sorted({r["cycles"] for k in ("big", "nobig") for r in groups[f][k]})
        ax.set_title(f"{f:g} Hz, {'/'.join(str(c) for c in cycles)} cycles")
        ax.set_xlabel("Φ (particles / cycle)")
        ax.legend(fontsize=7, loc="lower right")
    axes[0].set_ylabel("height D / settled bed height H")
    axes[0].set_ylim(0, 1)
    fig.savefig(path, dpi=130)
    return path


def force_ratios(big_paths, nobig_paths, skip_cycles=5):
    """The force ratio of every big-disk run against the run without the big
    disk at the same frequency and seed (else the first one at that frequency)."""
    nobig = {}
    for p in nobig_paths:
        run = read_run(p)
        nobig.setdefault(_freq(run), {})[int(run.scene.get("particles", {}).get("seed", 0))] = p
    rows = []
    for p in big_paths:
        run = read_run(p)
        f = _freq(run)
        if f not in nobig:
            continue
        seed = int(run.scene.get("particles", {}).get("seed", 0))
        ref = nobig[f].get(seed) or nobig[f][min(nobig[f])]
        fr = ForceRatio(skip_cycles=skip_cycles).compute(run, reference=read_run(ref))
        h = BigDiskHeight().compute(run)
        rows.append({"run": _label(p), "reference": _label(ref), "frequency": f, "ratio": fr.ratio,
                     "ratio_se": fr.ratio_se, "mean_with": fr.mean_with, "mean_without": fr.mean_without,
                     "frames": fr.frames_with, "reached_top": bool(h.reached_top)})
    by_f = {}
    for r in rows:
        by_f.setdefault(r["frequency"], []).append(r["ratio"])
    summary = {f: {"packings": len(v), "mean": float(np.mean(v)),
                   "sd": float(np.std(v, ddof=1)) if len(v) > 1 else None,
                   "se": float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else None}
               for f, v in sorted(by_f.items())}
    return rows, summary


# --------------------------------------------------------------------------- Fig. 1

def plot_velocity(paths, path, periods=50):
    fig = Figure(figsize=(4.2 * len(paths), 5.5), layout="constrained")
    axes = fig.subplots(1, len(paths), squeeze=False)[0]
    out = []
    for ax, p in zip(axes, paths):
        run = read_run(p)
        vf = VelocityField(periods=periods).compute(run)
        vf.plot(ax)
        big = "with big disk" if _big_column(run) is not None else "no big disk"
        ax.set_title(f"{_freq(run):g} Hz, {big}\nlast {vf.periods_used} cycles", fontsize=9)
        out.append({"run": _label(p), "frequency": _freq(run), "periods": vf.periods_used,
                    "centre_vy": vf.centre_vy, "wall_vy": vf.wall_vy, "mean_speed": vf.mean_speed})
    fig.savefig(path, dpi=130)
    return out


# --------------------------------------------------------------------------- Fig. 4

def plot_heights(paths, path):
    """Fig. 4: the big disk's height against time, one panel per radius and
    frequency with every packing; per run the waiting and rise times and the
    motion at the top (compare.box.top_motion)."""
    rows, curves = [], {}
    for p in paths:
        run = read_run(p)
        h = BigDiskHeight().compute(run)
        key = (h.big_radius, _freq(run))
        curves.setdefault(key, []).append((_label(p), h))
        rows.append({"run": _label(p), "frequency": _freq(run), "big_radius": h.big_radius,
                     "reached_top": bool(h.reached_top), "waiting_time_s": h.waiting_time_s,
                     "rise_time_s": h.rise_time_s, "top_height": h.top_height,
                     "seconds": float(h.times_s[-1]) if h.times_s.size else 0.0, "top_motion": top_motion(h)})
    keys = sorted(curves)
    fig = Figure(figsize=(8, 3.2 * len(keys)), layout="constrained")
    axes = fig.subplots(len(keys), 1, squeeze=False)[:, 0]
    for ax, key in zip(axes, keys):
        for label, h in curves[key]:
            lbl = label
            if h.reached_top:
                lbl += f": waits {h.waiting_time_s:.0f} s"
            ax.plot(h.times_s, h.height_smoothed, lw=0.9, label=lbl)
        ax.axhline(curves[key][0][1].top_height, ls="--", color="0.4", lw=0.7)
        ax.set_title(f"R = {key[0]:g} cm, {key[1]:g} Hz: {len(curves[key])} packings", fontsize=9)
        ax.set_ylabel("height above floor (cm)")
        ax.legend(fontsize=6, loc="upper left", ncol=2)
    axes[-1].set_xlabel("time of shaking (s)")
    fig.savefig(path, dpi=110)
    return rows


def height_groups(rows):
    """Fig. 4's numbers per (radius, frequency): rise fraction, waiting times,
    dip depth and regularity at the top, with a rank test between the two
    smallest radii at each frequency (scipy.stats.mannwhitneyu)."""
    from scipy.stats import mannwhitneyu
    groups = {}
    for r in rows:
        groups.setdefault((r["big_radius"], r["frequency"]), []).append(r)
    out = []
    for (radius, f), g in sorted(groups.items()):
        wait = [r["waiting_time_s"] for r in g if r["reached_top"]]
        tm = [r["top_motion"] for r in g if r["top_motion"]]
        out.append({"big_radius": radius, "frequency": f, "packings": len(g), "risen": len(wait),
                    "seconds": min(r["seconds"] for r in g), "waiting_s": wait,
                    "waiting_median_s": float(np.median(wait)) if wait else None,
                    "dip_fraction": [m["dip_fraction"] for m in tm], "regularity": [m["regularity"] for m in tm]})
    tests = []
    by_f = {}
    for g in out:
        by_f.setdefault(g["frequency"], []).append(g)
    for f, gs in by_f.items():
        if len(gs) < 2:
            continue
        a, b = gs[0], gs[1]
        t = {"frequency": f, "radii": [a["big_radius"], b["big_radius"]]}
        for key in ("waiting_s", "dip_fraction", "regularity"):
            if len(a[key]) >= 3 and len(b[key]) >= 3:
                t[key + "_p"] = float(mannwhitneyu(a[key], b[key], alternative="two-sided").pvalue)
        tests.append(t)
    return out, tests


# --------------------------------------------------------------------------- the ramp

def ramp_windows(path, window_cycles=10, skip_cycles=5):
    """Convection along a frequency ramp: Phi in consecutive windows of
    ``window_cycles`` cycles, each with the frequency at its middle.
    Returns rows with the depth-averaged Phi (mean over the 80 lines, the
    measure least sensitive to noise) and Phi_max."""
    run = read_run(path)
    sh = Shaker(run)
    total = int(sh.cycles(run.frames.time[-1]))
    big = _big_column(run) is not None
    hd = BigDiskHeight().compute(run) if big else None
    rows = []
    for start in range(skip_cycles, total - window_cycles + 1, window_cycles):
        cf = ConvectiveFlux(skip_cycles=start, max_cycles=window_cycles).compute(run)
        if cf.pairs_used < 2:
            continue
        t_mid = _time_at_cycle(sh, start + 0.5 * window_cycles)
        u = t_mid - sh.settle
        frac = min(1.0, max(0.0, (u - sh.ramp_start) / sh.ramp_time)) if sh.ramp_time > 0 else 0.0
        f_mid = sh.f0 + (sh.f1 - sh.f0) * frac
        row = {"cycle": start, "time_s": u, "frequency": f_mid, "phi_depth_mean": float(np.nanmean(cf.phi)),
               "phi_depth_mean_se": float(np.sqrt(np.nansum(cf.phi_se ** 2)) / cf.phi.size),
               "phi_max": cf.phi_max}
        if hd is not None:
            m = (hd.times_s >= u - 0.5 * window_cycles / f_mid) & (hd.times_s < u + 0.5 * window_cycles / f_mid)
            row["big_height"] = float(np.mean(hd.height[m])) if m.any() else None
        rows.append(row)
    return {"run": _label(path), "f_start": sh.f0, "f_end": sh.f1, "ramp_time": sh.ramp_time, "window_cycles": window_cycles,
            "big_disk": big, "windows": rows}


def _time_at_cycle(sh, c):
    lo, hi = sh.settle, sh.settle + 10.0 * (c + 1) / min(sh.f0, sh.f1)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if sh.cycles(mid) < c:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def onset_from_ramp(windows, level):
    """First frequency (in the ramp's direction) from which the depth-averaged
    Phi stays above ``level`` (up) or last one where it was above (down):
    the frequency at which convection is on/off, interpolated between windows."""
    f = np.array([w["frequency"] for w in windows])
    p = np.array([w["phi_depth_mean"] for w in windows])
    on = p > level
    if not on.any():
        return None
    if f[-1] > f[0]:  # up: first window from which it stays on
        k = len(on)
        while k > 0 and on[k - 1]:
            k -= 1
        if k == 0 or k == len(on):
            return None if k == len(on) else float(f[0])
        return float(f[k - 1] + (level - p[k - 1]) * (f[k] - f[k - 1]) / (p[k] - p[k - 1]))
    k = int(np.nonzero(on)[0][-1])  # down: last window on
    if k == len(on) - 1:
        return None
    return float(f[k] + (level - p[k]) * (f[k + 1] - f[k]) / (p[k + 1] - p[k]))


def plot_ramps(ramps, path, level):
    """Phi along each ramp: up red, down blue, the slower ramps dark and
    thicker; one legend entry per rate, direction and disk. The right panel
    zooms on the transition, with each run's switch marked on the level line."""
    fig = Figure(figsize=(10, 4.5), layout="constrained")
    axes = fig.subplots(1, 2, width_ratios=[3, 2])
    rates = sorted({r["ramp_time"] for r in ramps})
    seen = set()
    for r in ramps:
        f = [w["frequency"] for w in r["windows"]]
        p = [w["phi_depth_mean"] for w in r["windows"]]
        up = r["f_end"] > r["f_start"]
        slow = r["ramp_time"] != rates[0]
        rate = abs(r["f_end"] - r["f_start"]) / r["ramp_time"] if r["ramp_time"] else 0.0
        colour = ("darkred" if slow else "tab:red") if up else ("navy" if slow else "tab:blue")
        key = (up, rate, r["big_disk"])
        lbl = None
        if key not in seen:
            seen.add(key)
            n = sum(1 for q in ramps if (q["f_end"] > q["f_start"], abs(q["f_end"] - q["f_start"]) / q["ramp_time"]
                                         if q["ramp_time"] else 0.0, q["big_disk"]) == key)
            lbl = (f"{'up' if up else 'down'} {r['f_start']:g}→{r['f_end']:g} Hz at {rate:g} Hz/s, "
                   f"{'with' if r['big_disk'] else 'no'} big disk ({n} run{'s' if n > 1 else ''})")
        for ax in axes:
            ax.plot(f, p, "-" if up else "--", color=colour, lw=1.6 if slow else 0.6, alpha=1.0 if slow else 0.6,
                    label=lbl if ax is axes[0] else None)
        if r.get("onset") is not None:
            axes[1].plot([r["onset"]], [level], "^" if up else "v", color=colour, ms=5)
    for ax in axes:
        ax.axhline(level, color="0.4", lw=0.6, ls=":")
        ax.set_xlabel("shaking frequency f (Hz)")
    axes[1].set_xlim(2.55, 2.85)
    axes[1].set_ylim(-1, 3 * level + 5)
    axes[1].set_title("the transition; markers: each run's switch", fontsize=9)
    axes[0].set_ylabel(f"depth-averaged Φ over {ramps[0]['window_cycles']} cycles (particles / cycle)")
    axes[0].legend(fontsize=7, loc="upper left")
    fig.savefig(path, dpi=130)
    return path


# The paper: going up the transition occurs "almost exactly at the same
# frequency as when decreasing the frequency, i.e. there is no hysteresis", and
# runs differ by "less than 0.05 Hz". The margin for up - down is that
# resolution (docs/shaken_box.md, "The ramp").
HYSTERESIS_MARGIN = 0.05


def ramp_groups(ramps):
    """The ramp claim over packings: per ramp rate and big disk, the onset
    going up and the switch-off going down (mean, sd, range over packings: the
    transition's width between runs), and the hysteresis up - down with its
    95 % interval (Welch's t, statsmodels' CompareMeans) and its verdict
    against +-HYSTERESIS_MARGIN (compare/decision.py: verdict_independent,
    the three-way rule of the cross-engine suites)."""
    from statsmodels.stats.weightstats import CompareMeans

    from .decision import verdict_independent
    groups = {}
    for r in ramps:
        rate = abs(r["f_end"] - r["f_start"]) / r["ramp_time"] if r.get("ramp_time") else None
        key = (round(rate, 6) if rate else None, bool(r["big_disk"]))
        groups.setdefault(key, {"up": [], "down": []})["up" if r["f_end"] > r["f_start"] else "down"].append(
            r["onset"])
    out = []
    for (rate, big), g in sorted(groups.items(), key=lambda kv: (kv[0][0] or 0, kv[0][1])):
        row = {"rate_hz_per_s": rate, "big_disk": big}
        for d in ("up", "down"):
            v = [x for x in g[d] if x is not None]
            row[d] = v
            row[d + "_missing"] = len(g[d]) - len(v)
        if len(row["up"]) >= 2 and len(row["down"]) >= 2:
            lo, hi = CompareMeans.from_data(row["up"], row["down"]).tconfint_diff(alpha=0.05, usevar="unequal")
            row["hysteresis"] = float(np.mean(row["up"]) - np.mean(row["down"]))
            row["hysteresis_ci95"] = [float(lo), float(hi)]
            v = verdict_independent(row["down"], row["up"], HYSTERESIS_MARGIN)
            row["hysteresis_verdict"] = v["verdict"]
            row["hysteresis_ci90"] = [float(x) for x in v["ci90"]]
            row["hysteresis_mdd"] = v["mdd"]
        elif row["up"] and row["down"]:
            row["hysteresis"] = float(np.mean(row["up"]) - np.mean(row["down"]))
        out.append(row)
    return out


# --------------------------------------------------------------------------- all

def box_report(big, nobig, ramps, heights, velocity, out_dir, level=3.0, window_cycles=10):
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res = {}
    if big or nobig:
        groups = flux_by_frequency(big, nobig)
        plot_flux(groups, out / "fig3_flux.png")
        res["flux"] = {str(f): {k: [{kk: vv for kk, vv in r.items() if kk not in ("heights", "phi", "phi_se")}
                                    for r in g[k]] for k in g} for f, g in groups.items()}
    if big and nobig:
        rows, summary = force_ratios(big, nobig)
        res["force_ratio"] = {"runs": rows, "by_frequency": {str(k): v for k, v in summary.items()}}
    if velocity:
        res["velocity"] = plot_velocity(velocity, out / "fig1_velocity.png")
    if heights:
        res["heights"] = plot_heights(heights, out / "fig4_height.png")
        res["height_groups"], res["height_tests"] = height_groups(res["heights"])
    if ramps:
        rr = [ramp_windows(p, window_cycles) for p in ramps]
        for r in rr:
            r["onset"] = onset_from_ramp(r["windows"], level)
        plot_ramps(rr, out / "ramp_flux.png", level)
        res["ramps"] = rr
        res["ramp_level"] = level
        res["ramp_groups"] = ramp_groups(rr)
    res = clean_json(res)
    (out / "box_report.json").write_text(json.dumps(res, indent=1) + "\n")
    return res


def summary_markdown(res) -> str:
    lines = []
    if "flux" in res:
        lines += ["| f (Hz) | runs without / with big disk | depth-mean Φ without | with | Φ_max without | with |",
                  "|---|---|---|---|---|---|"]
        for f, g in res["flux"].items():
            def stat(rows, key):
                v = [r[key] for r in rows if r[key] is not None]
                return f"{np.mean(v):.2f} ± {np.std(v, ddof=1):.2f}" if len(v) > 1 else (f"{v[0]:.2f}" if v else "–")
            lines.append(f"| {f} | {len(g['nobig'])} / {len(g['big'])} | {stat(g['nobig'], 'phi_depth_mean')} | "
                         f"{stat(g['big'], 'phi_depth_mean')} | {stat(g['nobig'], 'phi_max')} | "
                         f"{stat(g['big'], 'phi_max')} |")
    if "force_ratio" in res:
        lines += ["", "| f (Hz) | packings | force ratio mean | sd over packings | s.e. |", "|---|---|---|---|---|"]
        for f, s in res["force_ratio"]["by_frequency"].items():
            sd = "–" if s["sd"] is None else f"{s['sd']:.3f}"
            se = "–" if s["se"] is None else f"{s['se']:.3f}"
            lines.append(f"| {f} | {s['packings']} | {s['mean']:.3f} | {sd} | {se} |")
    if "height_groups" in res:
        def ms(v, spec=".2f"):
            return "–" if not v else (f"{np.mean(v):{spec}} ± {np.std(v, ddof=1):{spec}}" if len(v) > 1
                                      else f"{v[0]:{spec}}")
        lines += ["", "| R (cm) | f (Hz) | risen / packings (within s) | waiting (s), median [all] | "
                  "dip depth / bed depth at the top | regularity at the top |", "|---|---|---|---|---|---|"]
        for g in res["height_groups"]:
            med = "–" if g["waiting_median_s"] is None else f"{g['waiting_median_s']:.0f}"
            lines.append(f"| {g['big_radius']:g} | {g['frequency']:g} | {g['risen']} / {g['packings']} "
                         f"({g['seconds']:.0f}) | {med} [{', '.join(f'{w:.0f}' for w in sorted(g['waiting_s']))}] | "
                         f"{ms(g['dip_fraction'])} | {ms(g['regularity'])} |")
        for t in res.get("height_tests", []):
            ps = ", ".join(f"{k[:-2]} p = {v:.2f}" for k, v in t.items() if k.endswith("_p"))
            lines.append(f"\nR = {t['radii'][0]:g} against {t['radii'][1]:g} cm at {t['frequency']:g} Hz "
                         f"(Mann-Whitney, two-sided): {ps or 'too few risen packings'}.")
    if "ramp_groups" in res:
        def spread(v):
            if not v:
                return "–"
            if len(v) == 1:
                return f"{v[0]:.3f}"
            return f"{np.mean(v):.3f} ± {np.std(v, ddof=1):.3f} (range {max(v) - min(v):.3f})"
        lines += ["", "| ramp rate (Hz/s) | big disk | packings up + down | on, going up: mean ± sd over packings | "
                  "off, going down | hysteresis up − down (95 % interval) | 90 % interval | "
                  f"verdict (margin ±{HYSTERESIS_MARGIN:g} Hz) |", "|---|---|---|---|---|---|---|---|"]
        for g in res["ramp_groups"]:
            hy = "–" if "hysteresis" not in g else f"{g['hysteresis']:+.3f} Hz"
            if "hysteresis_ci95" in g:
                hy += f" [{g['hysteresis_ci95'][0]:+.3f}, {g['hysteresis_ci95'][1]:+.3f}]"
            ci90 = (f"[{g['hysteresis_ci90'][0]:+.3f}, {g['hysteresis_ci90'][1]:+.3f}]"
                    if "hysteresis_ci90" in g else "–")
            lines.append(f"| {g['rate_hz_per_s'] if g['rate_hz_per_s'] is None else format(g['rate_hz_per_s'], 'g')} | "
                         f"{'yes' if g['big_disk'] else 'no'} | {len(g['up'])} + {len(g['down'])} | "
                         f"{spread(g['up'])} | {spread(g['down'])} | {hy} | {ci90} | "
                         f"{g.get('hysteresis_verdict', '–')} |")
    if "ramps" in res:
        lines += ["", f"| ramp | big disk | convection on/off at (depth-mean Φ > {res['ramp_level']:g}) |",
                  "|---|---|---|"]
        for r in res["ramps"]:
            on = "–" if r["onset"] is None else f"{r['onset']:.3f} Hz"
            lines.append(f"| {r['f_start']:g} → {r['f_end']:g} Hz | {'yes' if r['big_disk'] else 'no'} | {on} |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- placement and force readings

def placement_table(paths):
    """The big disk's start against its rise: runs grouped by ``big.gap`` (the
    gap between the floor and the disk's bottom as placed), each with the
    disk's height after settling and its waiting time (BigDiskHeight)."""
    groups = {}
    for p in paths:
        run = read_run(p)
        h = BigDiskHeight().compute(run)
        gap = float(run.scene.get("big", {}).get("gap", 2.0))
        groups.setdefault((gap, float(h.big_radius), _freq(run)), []).append(
            (h.start_height, h.waiting_time_s, float(h.times_s[-1]) if h.times_s.size else 0.0))
    lines = ["| R (cm) | f (Hz) | big.gap (cm) | disk bottom after settling (cm), median [range] | risen / packings "
             "(within s) | waiting (s), median [all] |", "|---|---|---|---|---|---|"]
    for (gap, radius, f), g in sorted(groups.items()):
        start = [x[0] for x in g]
        wait = sorted(x[1] for x in g if x[1] is not None)
        med = "–" if not wait else f"{np.median(wait):.1f}"
        lines.append(f"| {radius:g} | {f:g} | {gap:g} | {np.median(start):.1f} [{min(start):.1f}–{max(start):.1f}] | "
                     f"{len(wait)} / {len(g)} ({min(x[2] for x in g):.0f}) | {med} "
                     f"[{', '.join(f'{w:.1f}' for w in wait)}] |")
    return "\n".join(lines) + "\n"


def force_readings(big_paths, nobig_paths):
    """The force ratio under each reading of the paper's measure (ForceRatio:
    contact or total force, phase 0 or every phase, whole or lower half ring),
    each run with the big disk against the run without it from the same
    packing and frequency; mean and standard error over packings."""
    def key(run):
        return _freq(run), int(run.scene.get("particles", {}).get("seed", 1))
    nobig = {key(r): r for r in map(read_run, nobig_paths)}
    pairs = {}
    for r in map(read_run, big_paths):
        if key(r) in nobig:
            pairs.setdefault(key(r)[0], []).append((r, nobig[key(r)]))
    lines = ["| f (Hz) | packings | force | phases | ring | ratio, mean ± s.e. over packings |",
             "|---|---|---|---|---|---|"]
    for f, pp in sorted(pairs.items()):
        for force in ("contact", "total"):
            for phases in ("node", "all"):
                for half in (None, "lower"):
                    v = np.array([ForceRatio(force=force, phases=phases, half=half).compute(b, reference=n).ratio
                                  for b, n in pp])
                    se = v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else float("nan")
                    lines.append(f"| {f:g} | {len(v)} | {force} | {'phase 0' if phases == 'node' else 'all'} | "
                                 f"{half or 'whole'} | {v.mean():.3f} ± {se:.3f} |")
    lines += ["", "The paper's reading (contact force, phase 0, whole ring) by whether the box with the disk "
              f"convects: its depth-mean flux over the second half of the run at least {CONVECTING_LEVEL:g} "
              "particles a cycle (the ramps' switch level). Mean and 95 % interval (Student's t) over packings.", "",
              "| f (Hz) | box with the disk | packings | ratio, mean [95 %] |", "|---|---|---|---|"]
    for f, pp in sorted(pairs.items()):
        groups = {"convecting": [], "not convecting": []}
        for b, n in pp:
            groups["convecting" if convecting(b) else "not convecting"].append(
                ForceRatio(force="contact", phases="node").compute(b, reference=n).ratio)
        for name, v in groups.items():
            lines.append(f"| {f:g} | {name} | {len(v)} | {_mean_interval(v)} |")
    return "\n".join(lines) + "\n"


# The depth-mean convective flux (particles a cycle) above which a run counts
# as convecting: the level at which the ramps switch (onset_from_ramp).
CONVECTING_LEVEL = 3.0


def convecting(run, level=CONVECTING_LEVEL):
    """Whether the run's depth-mean flux Phi over the second half of its
    shaking is at least ``level`` particles a cycle."""
    total = int(Shaker(run).cycles(run.frames.time[-1]))
    cf = ConvectiveFlux(skip_cycles=max(1, total // 2)).compute(run)
    return bool(np.nanmean(cf.phi) >= level)


def _mean_interval(v, confidence=0.95):
    """"mean [lo, hi]": Student's t interval of the mean of v ("–" if empty)."""
    from scipy import stats
    v = np.asarray(v, dtype=float)
    if v.size == 0:
        return "–"
    if v.size == 1:
        return f"{v[0]:.3f}"
    lo, hi = stats.t.interval(confidence, v.size - 1, loc=v.mean(), scale=stats.sem(v))
    return f"{v.mean():.3f} [{lo:.3f}, {hi:.3f}]"
