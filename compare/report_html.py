"""The validation report as a static HTML page with its PNGs (compare validate).

Everything shown comes from the report dict that compare/validate.py also
writes as report.json. The page needs no server and no network: open
DIR/report.html in a browser. A small script at the end marks the body with
the number of images that loaded (data-images-loaded), which the browser test
reads back.
"""
from __future__ import annotations

import html
import warnings
from pathlib import Path

import numpy as np

ROW_COLOURS = {"native-paper": "C0", "native-linear": "C1", "native-leapfrog": "C1", "lammps": "C2",
               "native-viscel": "C3", "yade": "C4"}


def _fig(w, h):
    from matplotlib.figure import Figure
    return Figure(figsize=(w, h), layout="constrained")


def _fmt(x, digits=3):
    if x is None:
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def _ok_runs(r):
    return [x for x in r["runs"] if x["ok"]]


def _main_rows(rows):
    """The suite's own rows, without planted errors (ROW+MUTANT) and false-alarm groups (ROW@rR.G)."""
    return {k: v for k, v in rows.items() if "+" not in k and "@" not in k}


def drum_figures(name, case, outdir):
    from .reader import read_run
    from .spacetime import SpaceTime
    written = []
    for vname, rows in case["variants"].items():
        rows = _main_rows(rows)
        # the space-time plot needs a run's output (a run kept as its observables alone has none)
        shown = [r for r in rows if any(x.get("path") for x in _ok_runs(rows[r]))]
        names = [r for r in rows if _ok_runs(rows[r])]
        if not names:
            continue
        if shown:
            fig = _fig(3.2 * len(shown), 3.2)
            axes = fig.subplots(1, len(shown), squeeze=False)[0]
            for ax, row in zip(axes, shown):
                run = next(x for x in _ok_runs(rows[row]) if x.get("path"))
                SpaceTime().compute(read_run(run["path"])).plot(ax)
                ax.set_title(f"{row}, seed {run['seed']}", fontsize=9)
            written.append(outdir / f"{name}_spacetime.png")
            fig.savefig(written[-1], dpi=90)

        fig = _fig(6, 4)
        ax = fig.add_subplot()
        for row in names:
            runs = [x for x in _ok_runs(rows[row]) if x.get("surface_x")]
            if not runs:
                continue
            x = np.asarray(runs[0]["surface_x"], float)
            hs = [np.asarray(r["surface_height"], float) for r in runs if len(r["surface_height"]) == len(x)]
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # cells empty in every seed stay NaN
                h = np.nanmean(hs, axis=0)
            ax.plot(x, h, color=ROW_COLOURS.get(row), label=f"{row} ({len(hs)} seeds)")
        ax.set_xlabel("position across the drum")
        ax.set_ylabel("free-surface height")
        ax.legend(fontsize=8)
        ax.set_title(f"{name}: surface profiles, mean over seeds")
        written.append(outdir / f"{name}_surface.png")
        fig.savefig(written[-1], dpi=100)
    return written


def box_figures(name, case, outdir):
    written = []
    variants = case["variants"]
    top = max(variants, key=lambda v: float(v.rstrip("Hz")))
    rows = _main_rows(variants[top])
    fig = _fig(6, 4.5)
    ax = fig.add_subplot()
    for row, r in rows.items():
        runs = [x for x in _ok_runs(r) if x.get("phi") is not None]
        if not runs:
            continue
        phi = np.nanmean([np.asarray(x["phi"], float) for x in runs], axis=0)
        ax.plot(phi, runs[0]["phi_heights"], color=ROW_COLOURS.get(row), label=f"{row} ({len(runs)} packings)")
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_xlabel("Φ(D), grains per cycle (centre up minus walls)")
    ax.set_ylabel("height D above the floor (cm)")
    ax.set_title(f"{name} at {top}: convective flux")
    ax.legend(fontsize=8)
    written.append(outdir / f"{name}_phi.png")
    fig.savefig(written[-1], dpi=100)

    fig = _fig(6, 4)
    ax = fig.add_subplot()
    for row, r in rows.items():
        for k, x in enumerate(_ok_runs(r)):
            if x.get("height_t"):
                ax.plot(x["height_t"], x["height"], color=ROW_COLOURS.get(row), lw=0.8,
                        label=row if k == 0 else None)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("big disk's height above the floor (cm)")
    ax.set_title(f"{name} at {top}: big disk, every packing")
    ax.legend(fontsize=8)
    written.append(outdir / f"{name}_height.png")
    fig.savefig(written[-1], dpi=100)

    fig = _fig(6, 4)
    ax = fig.add_subplot()
    freqs = sorted(variants, key=lambda v: float(v.rstrip("Hz")))
    for j, row in enumerate(rows):
        f, p, lo, hi = [], [], [], []
        for v in freqs:
            c = variants[v].get(row, {}).get("convection")
            if c:
                f.append(float(v.rstrip("Hz")) + 0.01 * (j - 2))
                p.append(c["fraction"])
                lo.append(c["fraction"] - c["ci95"][0])
                hi.append(c["ci95"][1] - c["fraction"])
        ax.errorbar(f, p, yerr=[lo, hi], marker="o", capsize=3, color=ROW_COLOURS.get(row), label=row)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("fraction of packings convecting (95% interval)")
    ax.set_ylim(-0.05, 1.05)
    ax.legend(fontsize=8)
    ax.set_title(f"{name}: convection onset")
    written.append(outdir / f"{name}_threshold.png")
    fig.savefig(written[-1], dpi=100)
    return written


def _interval(ci):
    return f"[{_fmt(ci[0])}, {_fmt(ci[1])}]" if ci else "–"


def _side(s):
    if not isinstance(s, dict):
        return "–"
    if "fraction" in s:
        return f"{s['k']}/{s['n']}"
    if "mean" in s:
        und = f", {s['undefined']} undef." if s.get("undefined") else ""
        return f"{_fmt(s['mean'])} ± {_fmt(s['sd'])} ({s['n']}{und})"
    return "–"


def _verdict_class(c):
    if not c.get("gating"):
        return "info"
    return "pass" if c.get("verdict") == "equivalent" else "fail"


def write_report(report, outdir, name="report"):
    outdir = Path(outdir)
    figs = {}
    for cname, case in report["cases"].items():
        try:
            figs[cname] = (drum_figures if case["kind"] == "drum" else box_figures)(cname, case, outdir)
        except Exception as e:  # a missing figure must not lose the report's numbers
            figs[cname] = []
            case.setdefault("figure_errors", []).append(str(e))
    esc = html.escape
    out = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
           f"<title>Validation report: suite {esc(report['suite'])}</title>",
           "<style>body{font-family:sans-serif;max-width:1300px;margin:2em auto;padding:0 1em}"
           "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px;font-size:90%}"
           "th{background:#eee}.pass{background:#d8f0d8}.fail{background:#f6d0d0}.info{background:#f4f0d8}"
           "img{max-width:100%;border:1px solid #ddd;margin:4px 0}</style></head><body>"]
    verdict = report["verdict"]
    out.append(f"<h1>Validation report: suite <code>{esc(report['suite'])}</code></h1>")
    out.append(f"<p id='verdict' class='{'pass' if verdict == 'pass' else 'fail'}'>Verdict: <b>{esc(verdict)}</b>"
               f" ({len(report['failures'])} gating checks failed). Created {esc(report['created'])}. "
               "Rules and margins: docs/tolerances.md. Each comparison ends <i>equivalent</i> (the 90% interval "
               "of the difference lies inside ±margin), <i>different</i> (the 95% interval excludes 0 and reaches "
               "beyond the margin) or <i>inconclusive</i>. Scalars are compared paired by seed (every row starts "
               "from the same packings); yes/no observables by their fractions (Newcombe intervals). A comparison "
               f"gates when its two rows run the same model and the suite's runs give it a power of at least "
               f"{report.get('power_target', 0.8):g} to reach <i>equivalent</i>; the suite passes when every gating "
               "comparison is equivalent and every engine shows the rise threshold. MDD: the smallest true "
               "difference called different with probability 0.8.</p>")
    out.append("<h2>Summary</h2><table id='summary'><tr><th>case</th><th>variant</th><th>rows (A vs B)</th>"
               "<th>observable</th><th>A</th><th>B</th><th>B − A [95% interval]</th><th>margin</th><th>MDD</th>"
               "<th>verdict</th><th>gating</th></tr>")
    for c in report["comparisons"]:
        diff = f"{_fmt(c.get('difference'))} {_interval(c.get('ci95'))}" if c.get("difference") is not None else "–"
        out.append(f"<tr class='{_verdict_class(c)}'><td>{esc(c['case'])}</td><td>{esc(c['variant'])}</td>"
                   f"<td>{esc(c['a_row'])} vs {esc(c['b_row'])}</td><td>{esc(c['observable'])}</td>"
                   f"<td>{esc(_side(c.get('a')))}</td><td>{esc(_side(c.get('b')))}</td><td>{esc(diff)}</td>"
                   f"<td>{_fmt(c.get('margin'))}</td><td>{_fmt(c.get('mdd'))}</td>"
                   f"<td>{esc(c['verdict'])}{(': ' + esc(c['reason'])) if c.get('reason') else ''}</td>"
                   f"<td>{esc(c.get('why', ''))}</td></tr>")
    out.append("</table>")
    if report.get("thresholds"):
        out.append("<h2>Rise threshold per engine</h2><table id='thresholds'><tr><th>case</th><th>row</th>"
                   "<th>rose above / below</th><th>test</th><th>designed power</th><th>role</th></tr>")
        for t in report["thresholds"]:
            cls = ("pass" if t["present"] else "fail") if t["gating"] else "info"
            d = t.get("design") or {}
            out.append(f"<tr class='{cls}'><td>{esc(t['case'])}</td><td>{esc(t['row'])}</td>"
                       f"<td>{esc(t['above'])}: {_fmt(t['above_fraction'])}; {esc(t['below'])}: "
                       f"{_fmt(t['below_fraction'])}</td><td>{esc(t['reason'])}</td>"
                       f"<td>{_fmt(d.get('power'))}</td><td>{'gating' if t['gating'] else esc(d.get('why', 'reported'))}</td></tr>")
        out.append("</table>")
    if report.get("design"):
        out.append("<h2>Sample sizes</h2>")
        if report.get("pass_probability") is not None:
            out.append(f"<p>Engines that are truly the same pass every gating comparison with probability "
                       f"{_fmt(report['pass_probability'])} at the designed spreads.</p>")
        out.append("<table id='design'><tr><th>case</th><th>variant</th><th>pair</th><th>observable</th>"
                   "<th>margin</th><th>designed spread (sd of paired differences, or fraction)</th>"
                   "<th>runs for power 0.8</th><th>runs</th><th>power</th><th>role</th></tr>")
        for d in report["design"]:
            out.append(f"<tr class='{'pass' if d['gating'] else 'info'}'><td>{esc(d['case'])}</td>"
                       f"<td>{esc(d['variant'])}</td><td>{esc(d.get('pair', ''))}</td><td>{esc(d['observable'])}</td>"
                       f"<td>{_fmt(d['margin'])}</td>"
                       f"<td>{_fmt(d['spread'])}</td><td>{_fmt(d['required'])}</td><td>{d['n']}</td>"
                       f"<td>{_fmt(d['power'])}</td><td>{esc(d['why'])}</td></tr>")
        out.append("</table>")
    if report.get("detection"):
        out.append("<h2>Planted errors</h2><table id='mutants'><tr><th>mutant</th><th>gating observables it moves "
                   "beyond the margin</th><th>called different</th><th>missed</th><th>suite fails</th></tr>")
        for d in report["detection"]:
            cls = "pass" if not d["missed"] else "fail"
            out.append(f"<tr class='{cls}'><td>{esc(d['description'])}</td>"
                       f"<td>{esc(', '.join(d['effect_beyond_margin']) or '–')}</td>"
                       f"<td>{esc(', '.join(d['detected']) or '–')}</td><td>{esc(', '.join(d['missed']) or '–')}</td>"
                       f"<td>{'yes' if d['suite_fails'] else 'no'}</td></tr>")
        out.append("</table>")
        out.append("<table id='mutant_detail'><tr><th>mutant</th><th>case</th><th>variant</th><th>observable</th>"
                   "<th>effect (mutant − native) [95%]</th><th>margin</th><th>vs reference</th><th>gating</th></tr>")
        for m in report["mutants"]:
            out.append(f"<tr class='{'info' if not m['gating'] else ('pass' if m['detected'] else 'fail')}'>"
                       f"<td>{esc(m['mutant'])}</td><td>{esc(m['case'])}</td><td>{esc(m['variant'])}</td>"
                       f"<td>{esc(m['observable'])}</td><td>{_fmt(m['effect'])} {_interval(m['effect_ci95'])} "
                       f"({esc(m['effect_verdict'])})</td><td>{_fmt(m['margin'])}</td>"
                       f"<td>{esc(m['verdict'])} {_fmt(m['difference'])} {_interval(m['ci95'])}</td>"
                       f"<td>{'yes' if m['gating'] else 'no'}</td></tr>")
        out.append("</table>")
    if report.get("false_alarms"):
        fa = report["false_alarms"]
        out.append(f"<h2>False alarms ({fa['repeats']} repeats, fresh seeds against fresh seeds)</h2>"
                   "<table id='false_alarms'><tr><th>gating comparison</th><th>different</th><th>inconclusive</th>"
                   "<th>equivalent</th></tr>")
        for k, e in fa["per_comparison"].items():
            out.append(f"<tr><td>{esc(k)}</td><td>{e['different']}/{e['repeats']}</td>"
                       f"<td>{e['inconclusive']}/{e['repeats']}</td><td>{e['equivalent']}/{e['repeats']}</td></tr>")
        for k, e in fa["per_pair"].items():
            out.append(f"<tr><td>{esc(k)}: any gating comparison</td><td>{e['any_different']}/{e['repeats']}</td>"
                       f"<td>–</td><td>all: {e['all_equivalent']}/{e['repeats']}</td></tr>")
        out.append("</table>")
    for cname, case in report["cases"].items():
        out.append(f"<h2>{esc(cname)} ({esc(case['kind'])}: {esc(case['scene'])} {esc(' '.join(case['sets']))}; "
                   f"seeds {case['seeds']})</h2>")
        out.append("<table class='rows'><tr><th>variant</th><th>row</th><th>runs ok</th>"
                   + "".join(f"<th>{esc(k)}</th>" for k in _scalar_names(case))
                   + ("<th>convecting</th><th>rose</th>" if case["kind"] == "box" else "<th>formed</th>")
                   + "<th>at Coulomb cap</th><th>particle-steps/s (whole run)</th></tr>")
        for vname, rows in case["variants"].items():
            for row, r in _main_rows(rows).items():
                oks = _ok_runs(r)
                cells = [f"{len(oks)}/{len(r['runs'])}" + (f" (failed: {r['failed_runs']})" if r["failed_runs"] else "")]
                for k in _scalar_names(case):
                    s = r.get("summary", {}).get(k)
                    cells.append(f"{_fmt(s['mean'])} ± {_fmt(s['sd'])}" if s and s["mean"] is not None else "–")
                if case["kind"] == "box":
                    for key in ("convection", "rise"):
                        b = r.get(key)
                        cells.append(f"{b['k']}/{b['n']}" if b else "–")
                else:
                    b = r.get("fractions", {}).get("formed")
                    cells.append(f"{b['k']}/{b['n']}" if b else "–")
                caps = [x.get("coulomb_at_cap") for x in oks if x.get("coulomb_at_cap") is not None]
                cells.append(f"{np.mean(caps):.3g}" if caps else "–")
                cells.append(_fmt(r.get("speed")))
                out.append(f"<tr><td>{esc(vname)}</td><td>{esc(row)}</td>" + "".join(f"<td>{esc(c)}</td>" for c in cells) + "</tr>")
        out.append("</table>")
        if case.get("thresholds"):
            out.append("<table><tr><th>row</th><th>convection onset (Hz) [interval]</th><th>rise threshold (Hz) [interval]</th>"
                       "<th>risen without convection</th></tr>")
            for row, t in case["thresholds"].items():
                def th(x):
                    return f"{_fmt(x['threshold'])} [{_fmt(x['lo'])}, {_fmt(x['hi'])}] {x.get('threshold_position') or ''}"
                alone = sum(v[row].get("rose_without_convection", 0) for v in case["variants"].values() if row in v)
                out.append(f"<tr><td>{esc(row)}</td><td>{esc(th(t['convection']))}</td><td>{esc(th(t['rise']))}</td>"
                           f"<td>{alone}</td></tr>")
            out.append("</table>")
        for p in figs.get(cname, []):
            out.append(f"<p><img src='{esc(Path(p).name)}' alt='{esc(Path(p).stem)}'></p>")
        for e in case.get("figure_errors", []):
            out.append(f"<p class='fail'>figure not drawn: {esc(e)}</p>")
    out.append(f"<p>Every number: <a href='{name}.json'>{name}.json</a>. Speeds here are whole-run rates per CPU second "
               "(start-up and output included; runs cached before CPU time was recorded use wall-clock time, "
               "marked in report.json as timed_by); the interleaved benchmark is "
               "<code>compare bench</code>.</p>")
    out.append("<script>window.addEventListener('load',function(){var n=0;"
               "document.querySelectorAll('img').forEach(function(i){if(i.complete&&i.naturalWidth>0)n++;});"
               "document.body.setAttribute('data-images-loaded',n);"
               "document.body.setAttribute('data-images-total',document.images.length);});</script>")
    out.append("</body></html>")
    (outdir / f"{name}.html").write_text("\n".join(out))
    return outdir / f"{name}.html"


def _scalar_names(case):
    if case["kind"] == "drum":
        return ["slope_deg", "bands_final", "formation_rotations"]
    return ["bed_height", "phi_max", "top_time_s"]
