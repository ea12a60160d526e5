"""Does the default step give the paper's long-run observables? #A's first
1000 rotations at the paper's step 0.005 and at the default 0.01, several
seeds each (scripts/table1_campaign.sh writes them to RUN_DIR/step/; where
seed 1 at #A's own step is missing there, the #A run, cut at rotation 1000).

The decision rule, fixed before the runs (docs/table1.md, "The step"):
- gating, Welch TOST (compare.decision.verdict_independent): the band count
  at rotation 1000 (the most frequent count over rotations 975-1000) within
  one band pair (margin 2, the tolerance of docs/table1.md's verdicts), and
  the free-surface slope over the run's snapshots within 1.5 degrees (the
  validation suites' slope margin, docs/tolerances.md);
- reported: the rotation of the first merge (a lasting decrease of the band
  count, docs/observables.md "Long runs"), censored at 1000 when there is
  none, compared by a two-sided Mann-Whitney test (scipy), and the formation
  time.
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np

from .bands import band_events, mean_small_fraction
from .observe import analyse
from .reader import read_run
from .sectionv import pattern_excursion
from .table1 import EVENT_WINDOW, TOLERANCE_BANDS
from .table1 import _fmt as _f

ROTATIONS = 1000.0
MARGINS = {"bands_1000": float(TOLERANCE_BANDS), "slope_deg": 1.5}
NAME = re.compile(r"A_dt(?P<dt>[0-9.]+)_s(?P<seed>\d+)\.h5$")


def run_until(run, rotations):
    """The run cut at `rotations` (its snapshots and axial profiles up to then)."""
    t_end = rotations * run.rotation_period * (1 + 1e-9)
    fr = run.frames
    k = fr.time <= t_end
    frames = dataclasses.replace(fr, **{f: getattr(fr, f)[k] for f in
                                        ("time", "step", "id", "species", "diameter", "position", "velocity",
                                         "angular_velocity")})
    profile = run.profile
    if profile is not None:
        m = profile.time <= t_end
        profile = dataclasses.replace(profile, time=profile.time[m], small_fraction=profile.small_fraction[m])
    return dataclasses.replace(run, frames=frames, profile=profile)


def observe_one(path, dt, seed, done):
    """One run's observables up to ROTATIONS (dt None: the step the run ran at)."""
    run = read_run(path)
    dt = float(run.scene["integrator"]["dt"]) if dt is None else dt
    run = run_until(run, ROTATIONS)
    obs = analyse(run)
    b = obs["bands"]
    t, counts = np.asarray(b.time_rotations), np.asarray(b.counts)
    reached = float(t[-1]) if t.size else 0.0
    last = counts[(t > ROTATIONS - 25) & (t <= ROTATIONS + 1e-6)]
    events = band_events(t, counts, EVENT_WINDOW)
    merges = [e["rotation"] for e in events if e["kind"] == "merge"]
    try:
        slope = float(obs["surface"].slope_angle_deg)
    except (KeyError, TypeError, ValueError):
        slope = None
    if slope is not None and not np.isfinite(slope):  # no snapshot past the first rotations yet
        slope = None
    complete = done or reached >= ROTATIONS - 0.5
    st = obs["spacetime"]
    pe = pattern_excursion(st.time_rotations, st.small_fraction, mean_small_fraction(run),
                           float(run.scene["drum"]["length"]))
    return {"pattern": None if pe is None else dict(zip(("excursion", "wavelength", "rotations"), pe)),
            "file": str(path), "dt": dt, "seed": seed, "rotations_reached": reached, "complete": complete,
            "bands_1000": int(np.bincount(last).argmax()) if last.size and complete else None,
            "first_merge": merges[0] if merges else None,
            "slope_deg": slope, "formation_rotations": obs["formation"].formation_time, "events": events}


def step_runs(run_dir):
    """Every run of the step check in RUN_DIR (RUN_DIR/step/A_dt*_s*.h5), and
    RUN_DIR/A.h5 cut at rotation 1000 as seed 1 at its step where step/ has
    no such run."""
    run_dir = Path(run_dir)
    out = []
    for p in sorted((run_dir / "step").glob("A_dt*_s*.h5")):
        m = NAME.search(p.name)
        if m:
            out.append(observe_one(p, float(m["dt"]), int(m["seed"]), Path(f"{p}.done").exists()))
    a = run_dir / "A.h5"
    if a.exists():
        dt_a = float(read_run(a).scene["integrator"]["dt"])
        if not any(r["seed"] == 1 and r["dt"] == dt_a for r in out):
            out.insert(0, observe_one(a, None, 1, True))
    return out


def step_check(run_dir):
    """The runs and the verdicts (None when no step run is present)."""
    from scipy.stats import mannwhitneyu

    from .decision import verdict_independent
    runs = step_runs(run_dir)
    dts = sorted({r["dt"] for r in runs})
    if len(dts) != 2:
        return None
    small, large = dts
    done = [r for r in runs if r["complete"]]
    verdicts = {}
    for k, margin in MARGINS.items():
        a = [r[k] for r in done if r["dt"] == small and r[k] is not None]
        b = [r[k] for r in done if r["dt"] == large and r[k] is not None]
        verdicts[k] = verdict_independent(a, b, margin) | {"a": a, "b": b}
    # first merge, censored at ROTATIONS: no merge ranks after every merge
    a = [r["first_merge"] or ROTATIONS + 1 for r in done if r["dt"] == small]
    b = [r["first_merge"] or ROTATIONS + 1 for r in done if r["dt"] == large]
    mw = mannwhitneyu(a, b, alternative="two-sided") if len(a) >= 2 and len(b) >= 2 else None
    verdicts["first_merge"] = {"a": a, "b": b, "p": float(mw.pvalue) if mw else None}
    return {"steps": [small, large], "rotations": ROTATIONS, "margins": MARGINS, "runs": runs,
            "verdicts": verdicts}


def _wander(p):
    if p is None:
        return "–"
    return f"{p['excursion'] / p['wavelength']:.2f} ({p['excursion']:.1f} of {p['wavelength']:.1f}, {p['rotations']:.0f} rotations)"


def step_lines(check):
    """docs/table1.md's generated "The step" table and verdicts."""
    if check is None:
        return []
    small, large = check["steps"]
    lines = ["", "## The step", "",
             "#A's first 1000 rotations at the paper's step 0.005 and at the default 0.01. "
             "Generated from the step check's runs (`compare/table1_step.py`, which states the decision "
             "rule; the margins were fixed before the runs). Bands at rotation 1000: the most frequent count "
             "over rotations 975–1000. First merge: the first lasting decrease of the band count "
             f"({EVENT_WINDOW:g} rotations), \"none\" if there is none by rotation 1000.", "",
             "The pattern wanders: the range of the band pattern's axial position over the last stretch "
             "with one dominant mode, as a fraction of the spacing between alternate bands "
             "(docs/observables.md, \"Long runs\"; Fig. 1's claim: less than one).", "",
             "| step | seed | rotations | formation | bands at 1000 | first merge | events | slope | pattern wanders |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(check["runs"], key=lambda r: (r["dt"], r["seed"])):
        ev = ", ".join(f"{e['from']}→{e['to']} at {e['rotation']:.0f}" for e in r["events"]) or "–"
        merge = _f(r["first_merge"]) if r["first_merge"] is not None else ("none" if r["complete"] else "–")
        lines.append(f"| {r['dt']:g} | {r['seed']} | {r['rotations_reached']:.0f}"
                     f"{'' if r['complete'] else ' (running)'} | {_f(r['formation_rotations'])} | "
                     f"{_f(r['bands_1000'], 'd')} | {merge} | {ev} | {_f(r['slope_deg'], '.1f')}{'°' if r['slope_deg'] is not None else ''} | "
                     f"{_wander(r.get('pattern'))} |")
    lines += ["", f"| observable ({large:g} − {small:g}) | runs | difference | 90 % interval | margin | verdict |",
              "|---|---|---|---|---|---|"]
    for k, label in (("bands_1000", "bands at rotation 1000"), ("slope_deg", "slope (°)")):
        v = check["verdicts"][k]
        ci = v.get("ci90")
        ci_text = "–" if ci is None or any(c is None for c in ci) else f"[{ci[0]:+.2f}, {ci[1]:+.2f}]"
        diff = v.get("difference")
        lines.append(f"| {label} | {len(v['a'])} + {len(v['b'])} | {_f(diff, '+.2f')} | {ci_text} | "
                     f"±{v['margin']:g} | {v['verdict']} |")
    fm = check["verdicts"]["first_merge"]
    lines += ["", f"First merge (reported, not gating): {small:g}: "
              f"{', '.join('none' if x > ROTATIONS else f'{x:.0f}' for x in fm['a']) or '–'}; {large:g}: "
              f"{', '.join('none' if x > ROTATIONS else f'{x:.0f}' for x in fm['b']) or '–'}; "
              f"Mann–Whitney p = {_f(fm['p'], '.2f')}."]
    w = [r["pattern"]["excursion"] / r["pattern"]["wavelength"] for r in check["runs"] if r.get("pattern")]
    if w:
        lines += ["", f"The pattern wanders (reported): {np.min(w):.2f}–{np.max(w):.2f} of the spacing between "
                  f"alternate bands, median {np.median(w):.2f}, in the {len(w)} of {len(check['runs'])} runs whose "
                  f"dominant mode could be followed for 200 rotations or more; Fig. 1's pattern moves by less "
                  f"than one spacing."]
    return lines
