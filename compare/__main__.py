"""Command line:

    python3 -m compare quicklook OUT.h5 -o PLOT.png     space-time plot only
    python3 -m compare observe OUT.h5 --json            every observable as JSON
    python3 -m compare section-v RUN.h5...              drum: Section V's long-run measures as JSON
    python3 -m compare plot OUT.h5 -o DIR               every figure
    python3 -m compare table1 RUN_DIR -o docs/table1.md  the Table I reproduction
    python3 -m compare campaign-status DIR              how far a Table I campaign has got
    python3 -m compare onset RUN.h5... [--within S]     shaken box: onset frequency over packings
    python3 -m compare bench [-o DIR] [--rounds N]      native against LAMMPS, interleaved, with ratios
    python3 -m compare speed-accuracy -o DIR            binary-collision error against cost, per method
    python3 -m compare step-sweep -o DIR [--part P]     observables against the time step; the stability map
    python3 -m compare box-report --big RUN... --nobig RUN... [--ramp RUN...] [--height RUN...]
                       [--velocity RUN...] -o DIR      the shaken box's figures over many runs
    python3 -m compare box-placement RUN...             the big disk's start height against its waiting time
    python3 -m compare box-forces --big RUN... --nobig RUN...   the force ratio under each reading
    python3 -m compare views RUN.h5 -o OUT.png          the particles seen from above, below, obliquely
    python3 -m compare impacts [-o DIR] [--native-only]  Chung & Ooi's impacts per contact law, with analytic
                                                        limits, and in LAMMPS (linear law) and YADE (viscoelastic)


Expected failures (missing file, wrong schema, not a drum) print one line to
stderr naming the file and exit with status 2, so scripts can tell them apart
from crashes (which keep their traceback).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never needs a display

from matplotlib.figure import Figure  # noqa: E402

from .observe import DEFAULTS, observe, plot_all  # noqa: E402
from .reader import read_run  # noqa: E402
from .spacetime import SpaceTime  # noqa: E402


def quicklook(path, out, slice_width=None):
    """Write the space-time PNG of one run and return the path written."""
    run = read_run(path)
    st = SpaceTime(slice_width).compute(run)
    covered = float(st.time_rotations[-1]) if st.time_rotations.size else 0.0
    requested = run.scene.get("run", {}).get("rotations")
    rotations = f"{covered:.3g} rotations"
    if requested is not None and abs(float(requested) - covered) > 1e-6 * max(1.0, covered):
        rotations = f"{covered:.3g} of {float(requested):g} rotations"
    fig = Figure(figsize=(10, 4), layout="constrained")
    ax = st.plot(fig.add_subplot())
    ax.set_title(f"{run.attrs.get('engine', '?')}, scene {run.attrs.get('scene_name', '?')}: "
                 f"{rotations} (from {st.source})")
    out = Path(out)
    fig.savefig(out, dpi=150)
    return out


def _fail(command, run, exc):
    """An expected failure: one line naming the file, exit status 2."""
    msg = str(exc)
    if run not in msg:
        msg = f"{run}: {msg}"
    print(f"{command}: error: {msg}", file=sys.stderr)
    return 2


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m compare",
                                     description="Analysis of granular-frames HDF5 runs.")
    sub = parser.add_subparsers(dest="command", required=True)
    q = sub.add_parser("quicklook", help="space-time plot of the drum's axial segregation")
    q.add_argument("run", help="HDF5 file written by an engine")
    q.add_argument("-o", "--output", help="PNG to write (default: RUN with suffix _spacetime.png)")
    q.add_argument("--slice-width", type=float, default=None,
                   help="slice width when recomputing from frames (default 1.0)")
    o = sub.add_parser("observe", help="every drum observable of a run")
    o.add_argument("run")
    o.add_argument("--json", action="store_true", help="print JSON (the only format for now)")
    o.add_argument("--reference", help="shaken box: a run without the big disk, for the force ratio")
    sv = sub.add_parser("section-v", help="drum: Section V's long-run measures of each run, as JSON "
                                          "(docs/observables.md, \"Long runs\")")
    sv.add_argument("runs", nargs="+")
    pl = sub.add_parser("plot", help="write every figure of a run")
    pl.add_argument("run")
    pl.add_argument("-o", "--output", required=True, help="directory for the PNGs")
    on = sub.add_parser("onset", help="shaken box: rising fraction per frequency and the onset frequency")
    on.add_argument("runs", nargs="+", help="box runs with a big disk, one packing each")
    on.add_argument("--within", type=float, default=None, help="seconds of shaking allowed to reach the top")
    cs = sub.add_parser("campaign-status", help="how far each run of a Table I campaign has got")
    cs.add_argument("campaign_dir", help="the directory scripts/table1_campaign.sh runs in")
    tb = sub.add_parser("table1", help="docs/table1.md from a directory of Table I runs")
    tb.add_argument("run_dir")
    tb.add_argument("-o", "--output", default="docs/table1.md")
    tb.add_argument("--figures", default="docs/figures/table1")
    tb.add_argument("--earlier", default=None, metavar="JSON",
                    help="an earlier report's JSON (docs/table1.json): its finished runs stand in for runs "
                         "RUN_DIR has not finished")
    for sp in (o, pl):
        sp.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                        help="analysis parameter, e.g. formation.threshold=3 (keys: %s)" % ", ".join(DEFAULTS))
    be = sub.add_parser("bench", help="particle-steps/s of the native engine and LAMMPS on drum #A and the box")
    be.add_argument("-o", "--output", default="out/bench", help="directory for bench.json and bench.md")
    be.add_argument("--rounds", type=int, default=3, help="interleaved rounds; the median is reported")
    be.add_argument("--rotations", type=float, default=1.0, help="drum rotations timed per case")
    be.add_argument("--seconds", type=float, default=1.0, help="box seconds timed per case")
    be.add_argument("--only", action="append", default=[], help="only cases whose key contains this (repeatable)")
    be.add_argument("--yade", action="store_true", help="also YADE (and the native engine with YADE's law)")
    be.add_argument("--scaling", action="store_true",
                    help="also the native drum at about 1e3, 1e4 and 1e5 particles: cost per particle-step and memory")
    be.add_argument("--skin", action="store_true",
                    help="also the native drum and box over a ladder of neighbour-list skins (cost and builds per step)")
    br = sub.add_parser("box-report", help="shaken box: Fig. 1, 3, 4, force ratio, ramp onset over many runs")
    br.add_argument("--big", nargs="*", default=[], help="runs with the big disk (Fig. 3, force ratio)")
    br.add_argument("--nobig", nargs="*", default=[], help="runs without the big disk (Fig. 3, force ratio)")
    br.add_argument("--ramp", nargs="*", default=[], help="frequency-ramp runs (convection onset, hysteresis)")
    br.add_argument("--height", nargs="*", default=[], help="runs whose big-disk height is drawn (Fig. 4)")
    br.add_argument("--velocity", nargs="*", default=[], help="runs whose drift field is drawn (Fig. 1)")
    bp = sub.add_parser("box-placement", help="shaken box: the big disk's start height against its waiting time")
    bp.add_argument("runs", nargs="+")
    bf = sub.add_parser("box-forces", help="shaken box: the force ratio under each reading of the paper's measure")
    bf.add_argument("--big", nargs="+", required=True)
    bf.add_argument("--nobig", nargs="+", required=True)
    br.add_argument("--level", type=float, default=3.0,
                    help="ramp: depth-averaged Phi (particles/cycle) above which convection counts as on")
    br.add_argument("--window", type=int, default=10, help="ramp: cycles per window")
    br.add_argument("-o", "--output", required=True, help="directory for the PNGs and box_report.json")
    sa = sub.add_parser("speed-accuracy", help="binary-collision error against cost per law and integrator")
    sa.add_argument("-o", "--output", required=True, help="directory for collision_sweep.json and the PNGs")
    ss = sub.add_parser("step-sweep", help="scene observables against the time step, per method; the stability map")
    ss.add_argument("-o", "--output", required=True, help="directory: runs/ (the cache), step_sweep.json, PNGs")
    ss.add_argument("--part", choices=["accuracy", "stability", "all"], default="all")
    ss.add_argument("--engines", default="native,lammps,yade", help="comma-separated subset of native, lammps, yade")
    ss.add_argument("--cached-only", action="store_true", help="report the runs already in DIR; run nothing")
    gr = sub.add_parser("grid", help="observables of runs named SETUP[_fFREQ]_sSEED.h5, grouped by set-up")
    gr.add_argument("runs", nargs="+", help="run files (unfinished ones are left out)")
    gr.add_argument("-o", "--output", default=None, help="directory for grid.json")
    gr.add_argument("--reference", default=None, help="the set-up the others are compared with")
    va = sub.add_parser("validate", help="run the engines on a suite of scenes and write the agreement report")
    va.add_argument("--suite", choices=["quick", "full"], required=True)
    va.add_argument("-o", "--output", required=True, help="directory: runs/ (the cache), report.json, report.html")
    va.add_argument("--lanes", type=int, default=2, help="runs at a time (each engine on one thread)")
    va.add_argument("--rows", default=None,
                    help="comma-separated subset of rows (native-paper, native-linear, lammps, native-viscel, yade)")
    va.add_argument("--cases", default=None, help="comma-separated subset of the suite's cases (quick: drum_short, "
                    "box_rise; full: drum_A, box, box_threshold); the report covers only these")
    va.add_argument("--mutants", default=None,
                    help="also run the native rows of the gating pairs with planted model errors and report which the "
                         "suite calls different: comma-separated names or 'all' (compare/validate.py MUTANTS); "
                         "writes DIR/report_mutants.{json,html}")
    va.add_argument("--false-alarms", type=int, default=0, metavar="R",
                    help="also run the native rows of the gating pairs on 2R groups of fresh seeds and count how "
                         "often a group is called different from another; writes DIR/report_false_alarmsR.{json,html}")
    va.add_argument("--device", choices=["auto", "cpu", "gpu", "gpu-host"], default="auto",
                    help="where the native drum runs go: the CPU engine, one run per lane, or the GPU engine, the "
                         "seeds of a row as replicas of one process (docs/gpu.md); auto: gpu where `granular "
                         "devices` finds a CUDA device, else cpu")
    va.add_argument("--markdown", default=None, metavar="REPORT",
                    help="print DIR/REPORT.json (report, report_mutants, ...) as Markdown tables and exit")
    va.add_argument("--design", action="store_true",
                    help="print the suite's power analysis (margin, designed spread, runs needed, power) and exit")
    vw = sub.add_parser("views", help="drum: the particles seen from above, below or obliquely")
    vw.add_argument("run")
    vw.add_argument("-o", "--output", required=True, help="PNG to write")
    vw.add_argument("--frame", type=int, default=-1, help="frame index (default: the last)")
    vw.add_argument("--view", default="top,bottom", help="comma-separated views: top, bottom, oblique")
    vw.add_argument("--no-species", action="store_true", help="leave out the small-only and big-only rows")
    im = sub.add_parser("impacts", help="Chung & Ooi's benchmark impacts per contact law, with analytic limits")
    im.add_argument("-o", "--output", default="out/impacts", help="directory: runs/, impacts.json, impacts.png")
    im.add_argument("--native-only", action="store_true",
                    help="leave out the other engines (LAMMPS for the linear law, YADE for the viscoelastic law)")
    args = parser.parse_args(argv)

    if args.command == "impacts":
        from .impacts import impacts, markdown
        print(markdown(impacts(args.output, engines=not args.native_only)), end="")
        return 0

    if args.command == "views":
        from .views import write_views
        try:
            print(write_views(args.run, args.output, frame=args.frame, views=tuple(args.view.split(",")),
                              species_panels=not args.no_species))
        except (OSError, ValueError) as exc:
            return _fail("views", args.run, exc)
        return 0

    if args.command == "grid":
        from .grid import main as grid_main
        _, text = grid_main(args.runs, args.output, args.reference)
        print(text, end="")
        return 0

    if args.command == "validate":
        from .validate import MUTANTS, SUITE_PASS, design_table, pass_probability, validate
        cases = args.cases.split(",") if args.cases else None
        if args.design:
            table = design_table(args.suite, cases)
            for d in table:
                print(f"{d['case']:12s} {d['variant']:11s} {d['pair']:32s} {d['observable']:20s} "
                      f"margin {'–' if d['margin'] is None else format(d['margin'], 'g'):5s} "
                      f"spread {d['spread']!s:6s} runs needed {'–' if d['required'] is None else d['required']!s:5s} "
                      f"runs {d['n']:3d} "
                      f"power {d['power']:.3f}  {'gating' if d['gating'] else 'reported'}")
            print(f"a correct engine passes every gating comparison with probability "
                  f"{pass_probability(table):.3f} (designed for at least {SUITE_PASS})")
            return 0
        if args.markdown:
            import json as _json
            from .validate import report_markdown
            print(report_markdown(_json.loads((Path(args.output) / f"{args.markdown}.json").read_text())), end="")
            return 0
        mutants = list(MUTANTS) if args.mutants == "all" else (args.mutants.split(",") if args.mutants else [])
        rep = validate(args.suite, args.output, lanes=args.lanes,
                       rows=args.rows.split(",") if args.rows else None, cases=cases, mutants=mutants,
                       false_alarms=args.false_alarms, log=lambda m: print(m, file=sys.stderr, flush=True),
                       device=args.device)
        return 0 if rep["verdict"] == "pass" else 1

    if args.command == "speed-accuracy":
        from .speed_accuracy import report, table_markdown
        rows, figs = report(args.output)
        print(table_markdown(rows))
        for f in figs:
            print(f"wrote {f}", file=sys.stderr)
        return 0

    if args.command == "step-sweep":
        from .step_sweep import markdown, sweep
        parts = ("accuracy", "stability") if args.part == "all" else (args.part,)
        res = sweep(args.output, parts=parts, engines=tuple(args.engines.split(",")),
                    log=lambda m: print(m, file=sys.stderr, flush=True), cached_only=args.cached_only)
        print(markdown(res))
        return 0

    if args.command in ("box-placement", "box-forces"):
        from .box_report import force_readings, placement_table
        try:
            print(placement_table(args.runs) if args.command == "box-placement"
                  else force_readings(args.big, args.nobig), end="")
        except (OSError, ValueError) as exc:
            print(f"{args.command}: error: {exc}", file=sys.stderr)
            return 2
        return 0

    if args.command == "box-report":
        from .box_report import box_report, summary_markdown
        try:
            res = box_report(args.big, args.nobig, args.ramp, args.height, args.velocity, args.output,
                             level=args.level, window_cycles=args.window)
        except (OSError, ValueError) as exc:
            print(f"box-report: error: {exc}", file=sys.stderr)
            return 2
        print(summary_markdown(res))
        return 0

    if args.command == "bench":
        from .bench import main as bench_main
        return bench_main(args)

    if args.command == "onset":
        import json
        from .box import onset_from_runs
        try:
            print(json.dumps(onset_from_runs(args.runs, args.within), indent=2))
        except (OSError, ValueError) as exc:
            print(f"onset: error: {exc}", file=sys.stderr)
            return 2
        return 0

    if args.command == "campaign-status":
        from .table1 import campaign_status
        print(campaign_status(args.campaign_dir))
        return 0

    if args.command == "table1":
        from .table1 import table1
        print(table1(args.run_dir, args.output, args.figures, earlier=args.earlier))
        return 0

    if args.command in ("observe", "plot"):
        params = {}
        for kv in args.param:
            key, _, value = kv.partition("=")
            if key not in DEFAULTS or not value:
                print(f"{args.command}: error: bad --param {kv!r}; keys: {', '.join(DEFAULTS)}", file=sys.stderr)
                return 2
            try:
                params[key] = float(value)
            except ValueError:
                print(f"{args.command}: error: --param {key} needs a number, got {value!r}", file=sys.stderr)
                return 2
        try:
            if args.command == "observe":
                import json
                print(json.dumps(observe(args.run, params, reference=args.reference), indent=2))
            else:
                for path in plot_all(args.run, args.output, params):
                    print(path)
        except (OSError, ValueError) as exc:
            return _fail(args.command, args.run, exc)
        return 0

    if args.command == "section-v":
        import json

        from .observe import analyse
        from .reader import read_run
        from .sectionv import section_v
        out = {}
        for path in args.runs:
            try:
                run = read_run(path)
                out[path] = section_v(run, analyse(run))
            except (OSError, ValueError, KeyError) as exc:
                return _fail("section-v", path, exc)
        print(json.dumps(out, indent=2))
        return 0

    if args.command == "quicklook":
        out = args.output or Path(args.run).with_name(Path(args.run).stem + "_spacetime.png")
        try:
            written = quicklook(args.run, out, args.slice_width)
        except (OSError, ValueError) as exc:
            return _fail("quicklook", args.run, exc)
        print(written)
    return 0


if __name__ == "__main__":
    sys.exit(main())
