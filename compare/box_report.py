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
from .box import BigDiskHeight, ConvectiveFlux, ForceRatio, Shaker, VelocityField, _big_column
from .reader import read_run


def _freq(run) -> float:
    return round(Shaker(run).f0, 6)


def _label(path) -> str:
    return Path(path).stem


# --------------------------------------------------------------------------- Fig. 3 and the force ratio

def flux_by_frequency(big_paths, nobig_paths, skip_cycles=5):
    """Phi(D) of every run, grouped by frequency: {f: {"big": [...], "nobig": [...]}}.
    The line heights are fractions of each run's own settled bed height, so
    runs are averaged on D / H."""
    groups = {}
    for kind, paths in (("big", big_paths), ("nobig", nobig_paths)):
        for p in paths:
            run = read_run(p)
            cf = ConvectiveFlux(skip_cycles=skip_cycles).compute(run)
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
        ax.set_title(f"{f:g} Hz")
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
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    out = []
    for p in paths:
        run = read_run(p)
        h = BigDiskHeight().compute(run)
        lbl = f"R = {h.big_radius:g} cm, {_freq(run):g} Hz ({_label(p)})"
        if h.reached_top:
            lbl += f": waits {h.waiting_time_s:.1f} s, rises in {h.rise_time_s:.1f} s"
        ax.plot(h.times_s, h.height_smoothed, lw=1.0, label=lbl)
        out.append({"run": _label(p), "frequency": _freq(run), "big_radius": h.big_radius,
                    "reached_top": bool(h.reached_top), "waiting_time_s": h.waiting_time_s,
                    "rise_time_s": h.rise_time_s, "top_height": h.top_height})
    ax.set_xlabel("time of shaking (s)")
    ax.set_ylabel("height of the big disk's bottom above the floor (cm)")
    ax.legend(fontsize=7, loc="upper left")
    fig.savefig(path, dpi=130)
    return out


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
    return {"run": _label(path), "f_start": sh.f0, "f_end": sh.f1, "window_cycles": window_cycles,
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
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for r in ramps:
        f = [w["frequency"] for w in r["windows"]]
        p = [w["phi_depth_mean"] for w in r["windows"]]
        up = r["f_end"] > r["f_start"]
        style = "-" if up else "--"
        lbl = f"{'up' if up else 'down'} {r['f_start']:g}→{r['f_end']:g} Hz, {'with' if r['big_disk'] else 'no'} big disk"
        if r.get("onset") is not None:
            lbl += f" (on at {r['onset']:.3f} Hz)" if up else f" (off at {r['onset']:.3f} Hz)"
        ax.plot(f, p, style, lw=1.0, marker=".", ms=3, label=lbl)
    ax.axhline(level, color="0.4", lw=0.6, ls=":")
    ax.set_xlabel("shaking frequency f (Hz)")
    ax.set_ylabel(f"depth-averaged Φ over {ramps[0]['window_cycles']} cycles (particles / cycle)")
    ax.legend(fontsize=7, loc="upper left")
    fig.savefig(path, dpi=130)
    return path


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
    if ramps:
        rr = [ramp_windows(p, window_cycles) for p in ramps]
        for r in rr:
            r["onset"] = onset_from_ramp(r["windows"], level)
        plot_ramps(rr, out / "ramp_flux.png", level)
        res["ramps"] = rr
        res["ramp_level"] = level
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
    if "ramps" in res:
        lines += ["", f"| ramp | big disk | convection on/off at (depth-mean Φ > {res['ramp_level']:g}) |",
                  "|---|---|---|"]
        for r in res["ramps"]:
            on = "–" if r["onset"] is None else f"{r['onset']:.3f} Hz"
            lines.append(f"| {r['f_start']:g} → {r['f_end']:g} Hz | {'yes' if r['big_disk'] else 'no'} | {on} |")
    return "\n".join(lines) + "\n"
