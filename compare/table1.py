"""docs/table1.md from a directory of drum runs named after Table I's ids.

    /usr/bin/python3 -m compare table1 RUN_DIR -o docs/table1.md --figures docs/figures/table1

A file RUN_DIR/<id>.h5 is analysed if present (files still being written are
read as they are); RUN_DIR/Jsec.h5 and Ksec.h5 (short sections of #J and #K)
feed the surface-slope section. Hand-written findings in docs/table1_notes.md
are appended.

    ... --earlier docs/table1.json

keeps the finished runs of an earlier report (its JSON, docs/table1.json) for
the runs RUN_DIR has not finished: a run made again stands in for the earlier
one only once it has reached the paper's length. Each row keeps the commit
that ran it, and its figures stay those the earlier report drew.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .observe import analyse
from .reader import read_run

IDS = "ABCDEFGHIJKLMNPQRSTUVWXY"


def paper_rule(fr):
    """Section V.A: segregation iff bw > sw, or bw == sw and bb > ss."""
    if fr["gamma_s_bw"] != fr["gamma_s_sw"]:
        return fr["gamma_s_bw"] > fr["gamma_s_sw"]
    return fr["gamma_s_bb"] > fr["gamma_s_ss"]


def _segregated(obs):
    return obs["formation"].formation_time is not None and (obs["bands"].final or 0) >= 2


def _fmt(x, spec=".0f"):
    return "–" if x is None else format(x, spec)


TOLERANCE_BANDS = 2  # one band pair: docs/tolerances.md, "Drum band count"
EVENT_WINDOW = 50.0  # rotations a new band count must hold to count as an event


def parse_paper_bands(text):
    """Table I's "Bands" column: "8->6" -> (8, 6), "8" -> (8, 8), "none" -> (0, 0)."""
    if text in ("", None):
        return None
    if text == "none":
        return 0, 0
    a, _, b = text.partition("->")
    return int(a), int(b or a)


def verdict(paper, early, final, events, done):
    """agree / disagree / open, with the reason, for Table I's x->y against ours.
    Counts agree within TOLERANCE_BANDS (the paper's runs are single
    realisations); a change x->y needs a lasting change in the same direction."""
    if not done:
        return "open", "the run has not reached the paper's length"
    if paper is None:
        return "open", "no band count in Table I"
    x, y = paper
    if (y > 0) != (final > 0):
        return "disagree", f"{'segregated' if y else 'mixed'} in the paper, {'segregated' if final else 'mixed'} here"
    if abs(final - y) > TOLERANCE_BANDS:
        return "disagree", f"final count {final} against the paper's {y} (tolerance {TOLERANCE_BANDS})"
    if x != y:
        want = "merge" if y < x else "split"
        if not any(e["kind"] == want for e in events):
            return "disagree", f"the paper's {x}->{y} needs a lasting {want}; none here"
    if early is not None and abs(early - x) > TOLERANCE_BANDS and x > 0:
        return "agree", f"final count agrees; the early count {early} differs from the paper's {x}"
    return "agree", "counts within one band pair"


def run_summary(rid, run, obs, done, commit=None):
    """One Table I run as a JSON-ready dict (docs/table1.json)."""
    from .bands import band_events
    sc = run.scene
    paper = sc.get("paper", {})
    b, t = obs["bands"], obs["bands"].time_rotations
    counts = b.counts
    events = band_events(t, counts, EVENT_WINDOW)
    early50 = None
    sel = counts[(t >= 25) & (t <= 50)]
    if sel.size:
        early50 = int(np.bincount(sel).argmax())
    pb = parse_paper_bands(paper.get("bands", ""))
    surf = obs.get("surface")
    slope = None
    if surf is not None and surf.settled:  # not from the starting lattice alone
        try:
            slope = float(surf.slope_angle_deg)
        except (KeyError, TypeError, ValueError):
            slope = None
    v, why = verdict(pb, b.early, b.final or 0, events, done)
    return {"run": rid, "commit": commit, "done": done,
            "rotations_requested": sc.get("run", {}).get("rotations", paper.get("rotations")),
            "rotations_reached": float(t[-1]) if t.size else 0.0,
            "dt": sc.get("integrator", {}).get("dt"), "particles": int(run.frames.n_particles),
            "paper": {"bands": paper.get("bands", ""), "rotations": paper.get("rotations"), "N": paper.get("N"),
                      "figure": paper.get("figure", "")},
            "bands_first_50": early50, "bands_early": b.early, "bands_final": b.final,
            "events": events, "formation_rotations": obs["formation"].formation_time,
            "slope_deg": slope, "verdict": v, "reason": why}


def _scene_of(rid):
    """The shipped scene file of Table I run rid, as a dict (None if absent)."""
    import tomllib
    f = Path(__file__).resolve().parents[1] / "scenes" / "drum" / f"{rid}.toml"
    return tomllib.loads(f.read_text()) if f.exists() else None


def _scene_cells(sc):
    """The row's columns that come from the scene: L, D, rho, b, Omega, ends, init."""
    drum, parts = sc["drum"], sc["particles"]
    return (f"{drum['length']:g} | {drum['diameter']:g} | {parts['fill_density']:g} | "
            f"{parts['big_diameter']:g} | {drum['omega']:g} | {drum['ends'][0].upper()} | "
            f"{'M' if parts['initial_state'] == 'mixed' else 'S'}")


def _summary_segregated(r):
    """_segregated from a run's summary: bands formed, and two or more at the end."""
    return r.get("formation_rotations") is not None and (r.get("bands_final") or 0) >= 2


def _earlier_row(r, sc):
    """The table row of an earlier report's finished run r (sc: its scene),
    and whether the paper and the run segregate."""
    fr = sc.get("friction", {})
    paper = r["paper"]
    paper_seg = paper.get("bands") not in ("", "none", None)
    ours_seg = _summary_segregated(r)
    gamma = " ".join(f"{fr[k]:g}" for k in ("gamma_s_bb", "gamma_s_ss", "gamma_s_bw", "gamma_s_sw")) \
        if all(k in fr for k in ("gamma_s_bb", "gamma_s_ss", "gamma_s_bw", "gamma_s_sw")) else "–"
    row = (f"| {r['run']} | {_scene_cells(sc)} | {gamma} | {paper.get('N') or '–'} | {r['particles']} | "
           f"{paper.get('rotations') or 0:g} | {r['rotations_reached']:.0f} | {paper.get('bands') or '–'} | "
           f"{_fmt(r.get('bands_early'), 'd')}→{_fmt(r.get('bands_final'), 'd')} | "
           f"{_fmt(r.get('formation_rotations'))} | {'yes' if paper_seg else 'no'} / {'yes' if ours_seg else 'no'} | "
           f"{_mark(paper_seg, ours_seg)} | {_events_text(r['events'])} | "
           f"{r['verdict']}: {r['reason']} |")
    return row, paper_seg, ours_seg


def _mark(expected, ours, done=True):
    """✓ where ours matches the expectation; ✗ where it does not and the run is
    finished; "open" where a running run has not (yet) matched it."""
    return "✓" if expected == ours else ("✗" if done else "open")


def _rule_row(rid, sc, paper_seg, ours_seg, done=True):
    """The friction-rule row of run rid, where Sec. V.A's rule covers it (else None)."""
    fr, parts, drum = sc["friction"], sc["particles"], sc["drum"]
    if not (parts["initial_state"] == "mixed" and drum["ends"] == "periodic" and drum["length"] == 128
            and parts["fill_density"] == 0.3):
        return None
    return (f"| {rid} | {fr['gamma_s_bb']:g} | {fr['gamma_s_ss']:g} | {fr['gamma_s_bw']:g} | "
            f"{fr['gamma_s_sw']:g} | {parts['big_diameter']:g} | "
            f"{'yes' if paper_rule(fr) else 'no'} | {'yes' if paper_seg else 'no'} | "
            f"{'yes' if ours_seg else 'no'} | "
            f"{_mark(paper_rule(fr), ours_seg, done)} |")


def plot_band_count(ax, summary, t, counts):
    from .bands import lasting_count
    ax.step(t, counts, where="post", color="0.75", lw=0.5, label="count")
    ax.step(t, lasting_count(t, counts, EVENT_WINDOW), where="post", color="k", lw=1.2,
            label=f"lasting ({EVENT_WINDOW:g}-rotation mode)")
    for e in summary["events"]:
        ax.axvline(e["rotation"], color="tab:red" if e["kind"] == "merge" else "tab:blue", lw=0.8, ls="--")
    pb = parse_paper_bands(summary["paper"]["bands"])
    if pb:
        ax.axhline(pb[1], color="tab:green", lw=0.8, ls=":", label=f"paper's final {pb[1]}")
    ax.set_xlabel("rotations")
    ax.set_ylabel("bands")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=6, loc="upper right")


def _events_text(events):
    return ", ".join(f"{e['from']}→{e['to']} at {e['rotation']:.0f}" for e in events) or "–"


def section_v_claims(summaries, step=None):
    """Section V's claims, each with our measures and a verdict, from the runs
    present (compare/sectionv.py: measures, margins and verdict rules). A claim
    whose runs have not all reached the paper's length is open. Returns dicts:
    name (a short label), claim, ours, verdict, reason, runs (ids), running
    (ids), also (other evidence named in the runs column). ``step``: the step
    check (compare/table1_step.py), whose runs of #A give its wandering."""
    from . import sectionv as sv
    by = {r["run"]: r for r in summaries}
    claims = []

    def f(x, spec=".1f"):
        return "–" if x is None else format(x, spec)

    def add(name, claim, ours, rs, verdict_reason, also=None):
        running = [r["run"] for r in rs if not r["done"]]
        v, reason = verdict_reason
        if running:
            v, reason = "open", f"{', '.join('#' + x for x in running)} not at the paper's length; so far: {v}, {reason}"
        claims.append({"name": name, "claim": claim, "ours": ours, "verdict": v, "reason": reason,
                       "runs": [r["run"] for r in rs], "running": running, "also": also})

    def per_run(rs, judge):
        """One verdict for several runs, each judged alone."""
        parts = [judge(r) for r in rs]
        v, _ = sv.combine(parts)
        return v, "; ".join(f"#{r['run']} {pv}: {pr}" for r, (pv, pr) in zip(rs, parts))

    for rid in "VX":
        if rid in by and by[rid].get("section_v"):
            v = by[rid]["section_v"]
            add(f"#{rid} no mixing", f"#{rid}: \"no hint of mixing\"",
                f"interface width {f(v['interface_width_first_tenth'])} → {f(v['interface_width_last_tenth'])} "
                f"(first → last tenth of the run); mixed from {f(v.get('mixing_time'), '.0f')}",
                [by[rid]], sv.no_mixing_verdict(v))
    if by.get("W", {}).get("section_v"):
        v = by["W"]["section_v"]
        add("#W mixing", "#W: the initial bands vanish as the species mix",
            f"order parameter below threshold from rotation {f(v.get('mixing_time'), '.0f')}; interface width "
            f"{f(v['interface_width_first_tenth'])} → {f(v['interface_width_last_tenth'])}",
            [by["W"]], sv.mixing_verdict(v))
    if by.get("Y", {}).get("section_v"):
        r = by["Y"]
        v = r["section_v"]
        ev = ", ".join(f"{e['kind']} {e['from']}→{e['to']} at {e['rotation']:.0f}" for e in r["events"]) or "none"
        add("#Y events", "#Y: bands emerge and vanish (\"multiple band formation and disappearance events\")",
            f"events: {ev}", [r], sv.events_verdict(r["events"]))
        add("#Y exchange", "#Y: the segregated regions exchange positions",
            f"profile correlation with the start reaches {f(v.get('exchange_min'), '.2f')}"
            f"{' (exchanged from rotation ' + f(v.get('exchanged_at'), '.0f') + ')' if v.get('exchanged_at') else ''}",
            [r], sv.exchange_verdict(v))
        add("#Y band speed", "#Y: band speed about 0.01 d per rotation in the central portion",
            f"band speed {f(v['band_speed_median'], '.4f')} d per rotation ({sv.boundaries_text(v['band_speed_tracks'])} "
            f"followed)", [r], sv.band_speed_verdict(v))
    # the odd count is the claim of the initially mixed capped runs (#R-#U);
    # #X and #Y start as two halves
    capped = [r for r in summaries if "ends_last_tenth" in r.get("section_v", {})
              and (_scene_of(r["run"]) or {}).get("particles", {}).get("initial_state") == "mixed"]
    if capped:
        add("capped ends", "capped runs: odd band counts, the rougher big particles at both ends",
            "; ".join(f"#{r['run']} {r['bands_final']} bands, ends {'/'.join(r['section_v']['ends_last_tenth'])}"
                      for r in capped),
            capped, per_run(capped, lambda r: sv.capped_ends_verdict(r["bands_final"],
                                                                       r["section_v"]["ends_last_tenth"])))
    # Sec. V.B: with caps, formation starts at several interior places, not at the ends
    nucl = [r for r in capped if r["section_v"].get("onset_interior")]
    if nucl:
        def cell(r):
            v = r["section_v"]
            ends = " and ".join(f"{x:.0f}" if x is not None else "never" for x in v["onset_ends"]) or "–"
            return (f"#{r['run']}: interior bands begin at rotations "
                    f"{', '.join(f'{x:.0f}' for x in v['onset_interior'])} ({len(v['onset_interior'])} of "
                    f"{v['onset_interior_bands']}), the end bands at {ends}")
        add("capped nucleation", "capped runs: formation begins at several places at once; the ends are not nucleation sites",
            "; ".join(cell(r) for r in nucl), nucl, per_run(nucl, lambda r: sv.nucleation_verdict(r["section_v"])))
    # Sec. V.A-B: #A's pattern wanders along the axis as a whole, by less than
    # the spacing between alternate bands (Fig. 1); periodic patterns in
    # general are "free to translate along the axis" and capped ends hold
    # them still (#X: "completely stationary"). The band speed is the median
    # drift of the boundaries followed over 1000 rotations in the run's
    # central half; the excursion is the range of the dominant mode's
    # position (compare/sectionv.py). The first claim is judged on #A (the
    # step check's runs and its own), the second on the capped runs other
    # than #Y, whose bands move (its own claim above); the other periodic
    # runs are reported beside them.
    def motion(v):
        parts = []
        if v.get("band_speed_median") is not None:
            parts.append(f"band speed {v['band_speed_median']:.2g} d per rotation ({sv.boundaries_text(v['band_speed_tracks'])})")
        if v.get("pattern_excursion") is not None:
            parts.append(f"wanders over {v['pattern_excursion']:.1f} = {v['pattern_excursion'] / v['pattern_wavelength']:.2f}"
                         f" of the alternate-band spacing in {v['pattern_rotations']:.0f} rotations")
        return ", ".join(parts)

    def is_capped(r):
        return "ends_last_tenth" in r["section_v"]

    moving = [r for r in summaries if motion(r.get("section_v") or {})]
    ratios = [p["excursion"] / p["wavelength"] for p in
              (x.get("pattern") for x in ((step or {}).get("runs") or []) if x["complete"]) if p]
    a_runs = [r for r in moving if r["run"] == "A" and r["section_v"].get("pattern_excursion") is not None]
    parts = [("#A", sv.wander_verdict(r["section_v"], capped=False)) for r in a_runs]
    if ratios:
        parts.insert(0, (f"#A ({len(ratios)} runs of the step check)", sv.wander_many_verdict(ratios)))
    if parts:
        cells = [f"#A {motion(r['section_v'])}" for r in a_runs]
        if ratios:
            cells.insert(0, f"#A (step check) wanders over {min(ratios):.2f}–{max(ratios):.2f} of the "
                            f"alternate-band spacing, median {np.median(ratios):.2f}")
        cell = "; ".join(cells)
        v, _ = sv.combine([p for _, p in parts])
        add("#A wander", "#A's pattern wanders along the axis by less than the spacing between alternate bands "
            "(Fig. 1)", cell, a_runs, (v, "; ".join(f"{name} {pv}: {pr}" for name, (pv, pr) in parts)),
            also=f"the step check's {len(ratios)} runs of #A" if ratios else None)
    held = [r for r in moving if is_capped(r) and r["run"] != "Y"
            and r["section_v"].get("band_speed_median") is not None]
    if held:
        cells = "; ".join(f"#{r['run']} ({'capped' if is_capped(r) else 'periodic'}) "
                          f"{motion(r['section_v'])}" for r in moving)
        add("capped still", "capped patterns stay still; periodic ones are free to translate along the axis",
            cells, held, per_run(held, lambda r: sv.wander_verdict(r["section_v"], capped=True)))
    blur = [r for r in summaries if r["run"] in "APQ" and r.get("section_v")]
    if len(blur) > 1:
        # Sec. V.A: fuller drums segregate less thoroughly (band contrast),
        # with less sharp interfaces (width) and bands that take longer to
        # appear (formation time)
        def blur_cell(r):
            v = r["section_v"]
            return (f"#{r['run']} contrast {v['contrast_last_tenth']:.3f}, interface width "
                    f"{v['interface_width_last_tenth']:.1f}, bands formed at rotation "
                    f"{f(r.get('formation_rotations'), '.0f')}")
        got = {r["run"]: r for r in blur}
        vr = (sv.blur_verdict(*[(got[x]["section_v"], got[x].get("formation_rotations")) for x in "APQ"])
              if len(got) == 3 else ("inconclusive", "needs #A, #P and #Q"))
        add("#P/#Q blur", "#P, #Q (fuller drums) blur: wider interfaces in #P than in #A; in #Q less contrast than in #P, "
            "and bands that take longer to appear",
            f"over the last tenth of each run: {'; '.join(blur_cell(r) for r in blur)}", blur, vr)
    return claims


def section_v_lines(summaries):
    """Section V's claims over the runs (section_v_claims) as a Markdown table."""
    return claims_table(section_v_claims(summaries))


def claims_table(claims):
    """The claims of section_v_claims as a Markdown table."""
    if not claims:
        return []
    rows = [f"| {c['claim']} | {c['ours']} | {c['verdict']}: {c['reason']} | "
            f"{', '.join(['#' + x + (' (running)' if x in c['running'] else '') for x in c['runs']] + [c['also']] * bool(c.get('also')))} |"
            for c in claims]
    return ["", "## Section V's claims over the runs", "",
            "Measures of compare/sectionv.py (docs/observables.md, \"Long runs\"); the verdicts' rules and "
            "margins are in the same file, fixed from the paper's words and the spread between runs it calls "
            "alike. A claim whose runs have not reached the paper's length is open.", "",
            "| claim | ours | verdict | runs |", "|---|---|---|---|"] + rows


def verdict_summary(summaries, claims):
    """One paragraph counting the verdicts: Table I's x->y per run, and
    Section V's claims (section_v_claims)."""
    def count(items):
        by = {}
        for name, v in items:
            by.setdefault(v, []).append(name)
        return "; ".join(f"{v} {len(by[v])} ({', '.join(by[v])})" for v in ("agree", "disagree", "inconclusive", "open")
                         if v in by)
    table = count((f"#{r['run']}", r["verdict"]) for r in summaries)
    sec = count((c["name"], c["verdict"]) for c in claims)
    return ["", f"**Verdicts.** Table I's x→y: {table}." + (f" Section V's claims (below): {sec}." if claims else "")]


def table1(run_dir, out_md, fig_dir, notes=None, out_json=None, commit=None, earlier=None):
    os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")  # read runs still being written
    from matplotlib.figure import Figure

    run_dir, out_md, fig_dir = Path(run_dir), Path(out_md), Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    rows, figs, rule_rows, missing, summaries = [], [], [], [], []
    if commit is None and (run_dir.parent / "COMMIT").exists():
        commit = (run_dir.parent / "COMMIT").read_text().strip()
    kept = {}  # an earlier report's finished runs (--earlier)
    if earlier is not None:
        kept = {r["run"]: r for r in json.loads(Path(earlier).read_text())["runs"] if r.get("done")}
    from_earlier = []
    for rid in IDS:
        path = run_dir / f"{rid}.h5"
        if rid in kept and not (run_dir / f"{rid}.h5.done").exists():
            r = kept[rid]
            sc = _scene_of(rid)
            row, paper_seg, ours_seg = _earlier_row(r, sc)
            rows.append(row)
            rule = _rule_row(rid, sc, paper_seg, ours_seg)
            if rule:
                rule_rows.append(rule)
            summaries.append(r)
            from_earlier.append(r)
            png = fig_dir / f"{rid}_spacetime.png"
            if png.exists():
                figs.append((rid, png))
            continue
        if not path.exists():
            missing.append(rid)
            sc = _scene_of(rid)
            if sc is not None:
                paper = sc.get("paper", {})
                summaries.append({"run": rid, "commit": commit, "done": False,
                                  "rotations_requested": sc["run"]["rotations"], "rotations_reached": 0.0,
                                  "paper": {k: paper.get(k) for k in ("bands", "rotations", "N", "figure")},
                                  "verdict": "open", "reason": "not started", "events": [], "section_v": {}})
                rows.append(f"| {rid} | {_scene_cells(sc)} | – | "
                            f"{paper.get('N', '–')} | – | {paper.get('rotations', 0):g} | 0 | "
                            f"{paper.get('bands') or '–'} | – | – | – | – | – | open: not started |")
            continue
        run = read_run(path)
        obs = analyse(run)
        sc = run.scene
        paper, drum, fr, parts = sc.get("paper", {}), sc["drum"], sc["friction"], sc["particles"]
        done = (run_dir / f"{rid}.h5.done").exists()
        t = obs["spacetime"].time_rotations
        paper_bands = paper.get("bands", "")
        paper_seg = paper_bands not in ("", "none")
        ours_seg = _segregated(obs)
        b = obs["bands"]
        summary = run_summary(rid, run, obs, done, commit)
        from .sectionv import section_v
        summary["section_v"] = section_v(run, obs)
        summaries.append(summary)
        rows.append(
            f"| {rid} | {drum['length']:g} | {drum['diameter']:g} | {parts['fill_density']:g} | "
            f"{parts['big_diameter']:g} | {drum['omega']:g} | {drum['ends'][0].upper()} | "
            f"{'M' if parts['initial_state'] == 'mixed' else 'S'} | "
            f"{fr['gamma_s_bb']:g} {fr['gamma_s_ss']:g} {fr['gamma_s_bw']:g} {fr['gamma_s_sw']:g} | "
            f"{paper.get('N', '–')} | {run.frames.n_particles} | {paper.get('rotations', 0):g} | "
            f"{t[-1]:.0f}{'' if done else ' (running)'} | {paper_bands or '–'} | {_fmt(b.early, 'd')}→{_fmt(b.final, 'd')} | "
            f"{_fmt(obs['formation'].formation_time)} | {'yes' if paper_seg else 'no'} / {'yes' if ours_seg else 'no'} | "
            f"{_mark(paper_seg, ours_seg, done)} | {_events_text(summary['events'])} | "
            f"{summary['verdict']}: {summary['reason']} |")
        rule = _rule_row(rid, sc, paper_seg, ours_seg, done)
        if rule:
            rule_rows.append(rule)
        fig = Figure(figsize=(7, 3.8), layout="constrained")
        top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(2.6, 1.2))
        ax = obs["spacetime"].plot(top)
        plot_band_count(bottom, summary, b.time_rotations, b.counts)
        ax.set_title(f"#{rid}: {t[-1]:.0f} rotations, bands {_fmt(b.early, 'd')}→{_fmt(b.final, 'd')} "
                     f"(paper {paper_bands or 'none'} over {paper.get('rotations', 0):g})", fontsize=9)
        out = fig_dir / f"{rid}_spacetime.png"
        fig.savefig(out, dpi=70)
        figs.append((rid, out))

    # The paper's particle views (Figs. 2, 6, 8, 17) from the last snapshot of each run present
    view_figs = []
    for rid, views, species, fig_no in (("A", ("top",), True, "2"), ("J", ("top", "oblique"), True, "6"),
                                        ("K", ("top", "bottom"), True, "8"), ("Y", ("top",), True, "17")):
        path = run_dir / f"{rid}.h5"
        if rid in {r["run"] for r in from_earlier}:
            view_figs += [(f"#{rid} (the paper's Fig. {fig_no}), frame {p.stem.rsplit('_', 1)[1]}", p)
                          for p in sorted(fig_dir.glob(f"{rid}_views_*.png"))]
            continue
        if not path.exists():
            continue
        from .views import drum_views
        vrun = read_run(path)
        frames = [vrun.frames.n_frames - 1] if rid != "Y" else sorted({0, vrun.frames.n_frames // 2,
                                                                      vrun.frames.n_frames - 1})
        for k in frames:
            out = fig_dir / f"{rid}_views_{k}.png"
            drum_views(vrun, frame=k, views=views, species_panels=species).savefig(out, dpi=60)
            view_figs.append((f"#{rid} (the paper's Fig. {fig_no}), frame {k}", out))

    surf_rows = []
    for name, label in (("J", "#J (Ω = 0.5), last 10 snapshots"), ("K", "#K (Ω = 0.1), last 10 snapshots"),
                        ("Jsec", "#J section (Ω = 0.5)"), ("Ksec", "#K section (Ω = 0.1)")):
        path = run_dir / f"{name}.h5"
        if not path.exists():
            continue
        run = read_run(path)
        obs = analyse(run)
        if "surface" not in obs:
            continue
        s = obs["surface"]
        by = s.slope_angle_deg_by_species
        surf_rows.append(f"| {label} | {run.scene['drum']['length']:g} | {run.frames.n_particles} | "
                         f"{obs['spacetime'].time_rotations[-1]:.0f} | {s.slope_angle_deg:.1f}° | "
                         f"{by.get('small', float('nan')):.1f}° | {by.get('big', float('nan')):.1f}° |")
        fig = Figure(figsize=(5, 4.5), layout="constrained")
        s.plot(fig.add_subplot())
        fig.savefig(fig_dir / f"{name}_surface.png", dpi=80)
        figs.append((name, fig_dir / f"{name}_surface.png"))

    rel = os.path.relpath(fig_dir, out_md.parent)
    lines = ["# Table I of Rapaport (2002), reproduced by the native engine", "",
             "Generated by `/usr/bin/python3 -m compare table1` from the runs in "
             f"`{run_dir}`; the analysis is `compare observe` with its default parameters "
             "(`docs/observables.md`). Columns as in the paper's Table I; γ_s in the order bb ss bw sw. "
             "\"rotations ours\" is how far the run has got (\"running\" until it reaches the paper's count). "
             "Bands: early→final as defined in docs/observables.md. Formation: rotations. "
             "Segregated: paper (a band count in Table I) / ours (bands formed and present at the end). "
             "Events: changes of the band count lasting 50 rotations; the last column compares the paper's "
             "x→y with ours (docs/observables.md, \"Long runs\"). Every run is at its scene's default step "
             "(docs/table1.json gives it, and the commit that ran it).", "",
             "| run | L | D | ρ | b | Ω | ends | init | γ_s | N paper | N ours | rotations paper | rotations ours "
             "| bands paper | bands ours | formation | segregated paper / ours | agree | events (lasting "
             f"{EVENT_WINDOW:g} rotations) | paper's x→y |",
             "|" + "---|" * 20]
    lines += rows
    if from_earlier:
        by_commit = {}
        for r in from_earlier:
            by_commit.setdefault(r.get("commit") or "unknown", []).append("#" + r["run"])
        lines += [""] + [f"From the earlier report (`{earlier}`), made by commit {c[:7]} and not yet "
                         f"made again to the paper's length here: {', '.join(ids)}." for c, ids in by_commit.items()]
    if missing:
        lines += ["", f"Not run yet: {', '.join('#' + m for m in missing)}."]
    from .table1_step import step_check, step_lines
    step = step_check(run_dir)
    claims = section_v_claims(summaries, step)
    lines += verdict_summary(summaries, claims)
    lines += ["", "## The friction rules of Sec. V.A (runs #A–#H, #L–#N)", "",
              "The paper's summary: segregation when γ_s^bw > γ_s^sw; with equal wall coefficients only "
              "when γ_s^bb > γ_s^ss; none when γ_s^bw < γ_s^sw.", "",
              "| run | γ_s^bb | γ_s^ss | γ_s^bw | γ_s^sw | b | rule predicts | Table I | ours | ours vs rule |",
              "|---|---|---|---|---|---|---|---|---|---|"] + rule_rows
    lines += claims_table(claims)
    if surf_rows:
        lines += ["", "## Free-surface slope (Fig. 9)", "",
                  "Short periodic sections of the #J/#K cylinder (D = 24); the slope is an axial average. "
                  "Fit over the central half of the free surface (docs/observables.md). The paper's visual "
                  "estimate for #J and #K: 10°–20°.", "",
                  "| run | L | N | rotations | slope | small surface | big surface |", "|---|---|---|---|---|---|---|"]
        lines += surf_rows
    if view_figs:
        lines += ["", "## Views of the particles", ""]
        lines += [f"![{label}]({rel}/{p.name})" for label, p in view_figs]
    lines += ["", "## Figures", ""]
    lines += [f"![{rid}]({rel}/{p.name})" for rid, p in figs]
    lines += step_lines(step)
    notes = Path(notes) if notes else out_md.with_name("table1_notes.md")
    if notes.exists():
        lines += ["", notes.read_text().rstrip()]
    out_md.write_text("\n".join(lines) + "\n")
    out_json = Path(out_json) if out_json else out_md.with_suffix(".json")
    out_json.write_text(json.dumps({"runs": summaries, "section_v_claims": claims, "step_check": step, "tolerance_bands": TOLERANCE_BANDS,
                                    "event_window_rotations": EVENT_WINDOW}, indent=1, default=float) + "\n")
    return out_md


def campaign_status(campaign_dir):
    """One line per run of a campaign directory (scripts/table1_campaign.sh):
    the Table I runs, then the step check's (runs/step/): rotations reached
    against requested, and whether it finished, runs or failed."""
    from .reader import open_h5

    os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")
    runs = Path(campaign_dir) / "runs"

    def line(name, path):
        if not path.exists():
            return f"{name:14} {'-':>9} {'-':>7}  waiting"
        try:
            with open_h5(path) as h5:
                scene = json.loads(h5.attrs["scene_json"])
                period = float(h5.attrs["rotation_period"])
                t = h5["profile/time"]
                reached = float(t[t.shape[0] - 1]) / period if t.shape[0] else 0.0
        except (OSError, KeyError, ValueError) as exc:
            return f"{name:14} {'?':>9} {'?':>7}  unreadable ({exc})"
        log = path.with_suffix(".log")
        text = log.read_text(errors="replace") if log.exists() else ""
        state = ("done" if path.with_name(path.name + ".done").exists()
                 else "failed" if "unstable" in text or "error" in text else "running or stopped")
        return f"{name:14} {reached:9.1f} {scene['run']['rotations']:7g}  {state}"

    lines = [f"{'run':14} {'reached':>9} {'of':>7}  state"]
    lines += [line(rid, runs / f"{rid}.h5") for rid in IDS]
    lines += [line(p.stem, p) for p in sorted((runs / "step").glob("*.h5"))]
    return "\n".join(lines)
