"""/usr/bin/python3 -m yade_cases run SCENE -o OUT.h5 [--set key=value]... [--threads N] [--force] [-q]

Runs a scene file from scenes/ in YADE 2023.02a and writes the common HDF5
schema. The native engine resolves the scene (`granular init`, as for
lammps_cases); the initial state and the scene go to a work directory
OUT.h5.yade/, and `yade -n -x -jN yade_cases/{drum,box,particles}_case.py
WORKDIR OUT.h5` runs the case. Particles scenes run YADE's viscoelastic law
(contact.law is set to "viscel"); `run_particles` runs several in one YADE
process. Exit status: YADE's, or 2 when the scene is refused (before
anything runs) or the output exists (without --force)."""

from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

from lammps_cases.scene import (ROOT, SceneRefused, refuse_frozen_rotation, is_drum, load_initial,
                                refusal_message, scene_kind)

from .common import write_workdir

HERE = Path(__file__).resolve().parent
BOX_INTEGRATORS = ("leapfrog", "gear")  # the box's integrator.kind values


def refuse_unrepresentable(ini) -> None:
    """Raises SceneRefused, naming the key, for what YADE's cases cannot represent."""
    s = ini.scene
    refuse_frozen_rotation(s, "YADE")
    if ini.kind == "drum":
        kind = s.get("integrator", {}).get("kind", "leapfrog")
        if kind != "leapfrog":
            raise SceneRefused(f"\"{kind}\": YADE runs its leapfrog (NewtonIntegrator) only", key="integrator.kind")
        if s.get("contact", {}).get("law", "linear") != "linear":
            raise SceneRefused("YADE runs the linear law (mapped from Rapaport's) only", key="contact.law")
    elif ini.kind == "shaken_box":
        c = s.get("contact", {})
        if c.get("damping", "normal") != "normal":
            raise SceneRefused("\"literal\": YADE's ViscElPhys damps the normal relative velocity only",
                               key="contact.damping")
        if c.get("law", "poeschel_herrmann") != "poeschel_herrmann":
            raise SceneRefused(f"\"{c.get('law')}\": not set up in the YADE box case", key="contact.law")
        if s.get("box", {}).get("walls", "particles") != "particles":
            raise SceneRefused("\"smooth\": smooth walls are not set up in the YADE box case, which moves walls "
                               "of particles", key="box.walls")
        # The native engine's choice and words (native/src/scene/box_scene.cpp); YADE
        # runs its leapfrog for either.
        kind = s.get("integrator", {}).get("kind", "leapfrog")
        if kind not in BOX_INTEGRATORS:
            allowed = ", ".join(f"\"{k}\"" for k in BOX_INTEGRATORS)
            raise SceneRefused(f"unknown value \"{kind}\" (allowed: {allowed})", key="integrator.kind")
    elif ini.kind == "particles":
        kind = s.get("integrator", {}).get("kind", "leapfrog")
        if kind != "leapfrog":
            raise SceneRefused(f"\"{kind}\": YADE runs its leapfrog (NewtonIntegrator) only", key="integrator.kind")
        if "viscel_law" not in ini.derived:
            raise SceneRefused(f"YADE's law cannot be mapped here: {ini.derived.get('linear_law')}",
                               key="contact.law")
    else:
        raise SceneRefused(f"\"{ini.kind}\": no YADE case", key="scene.kind")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m yade_cases", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene in YADE")
    r.add_argument("scene")
    r.add_argument("-o", "--output", required=True)
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    r.add_argument("--threads", type=int, default=1, help="YADE's OpenMP threads (yade -jN); 1 is repeatable")
    r.add_argument("--segments", type=int, default=None,
                   help="drum: segments around the circumference (default: the fewest, in multiples of 8, "
                        "with radius error <= 0.01)")
    r.add_argument("--force", action="store_true", help="overwrite an existing output file")
    r.add_argument("-q", "--quiet", action="store_true")
    r.add_argument("--timed-from", type=float, default=None,
                   help="also time the speed alone from this many rotations (drum) or seconds of shaking "
                        "(box) on: attribute timed_atom_steps_per_second (compare bench)")
    args = ap.parse_args(argv)

    out = Path(args.output)
    if out.exists() and not args.force:
        print(f"yade_cases: error: {out}: output file exists; pass --force to overwrite it (it was left untouched)",
              file=sys.stderr)
        return 2
    yade = shutil.which("yade")
    if yade is None:
        print("yade_cases: error: `yade` is not on PATH (apt-get install yade; scripts/setup.sh)", file=sys.stderr)
        return 2
    if scene_kind(args.scene) == "particles":
        try:
            run_particles([(args.scene, out, args.set)], threads=args.threads, quiet=args.quiet)
        except SceneRefused as exc:
            print(f"yade_cases: error: {exc}", file=sys.stderr)
            return 2
        except RuntimeError as exc:
            print(f"yade_cases: error: {exc}", file=sys.stderr)
            return 1
        return 0
    try:
        drum = is_drum(args.scene)
        ini = load_initial(args.scene, args.set, extra_sets=["contact.law=linear"] if drum else [])
        refuse_unrepresentable(ini)
    except SceneRefused as exc:
        print(f"yade_cases: error: {refusal_message(exc, args.scene, args.set)}", file=sys.stderr)
        return 2

    out = out.resolve()  # yade runs from the repository root
    work = Path(str(out) + ".yade")
    options = {"quiet": args.quiet, "threads": args.threads, "segments": args.segments,
               "scene_path": str(args.scene), "sets": args.set}
    if args.timed_from is not None:
        dt = float(ini.scene["integrator"]["dt"])
        t = (args.timed_from * 2 * math.pi / float(ini.scene["drum"]["omega"]) if ini.kind == "drum"
             else float(ini.scene["run"]["settle"]) + args.timed_from)
        options["timed_from_step"] = int(math.floor(t / dt + 0.5))
    write_workdir(work, ini, options)
    script = HERE / ("drum_case.py" if ini.kind == "drum" else "box_case.py")
    if out.exists():
        out.unlink()
    cmd = [yade, "-n", "-x", f"-j{max(1, args.threads)}", str(script), str(work), str(out)]
    env = dict(os.environ, OMP_NUM_THREADS=str(max(1, args.threads)))
    # YADE's banner and its own messages go to the work directory's log; errors also to stderr
    with open(work / "yade.log", "w") as log:
        res = subprocess.run(cmd, cwd=ROOT, env=env, stdout=log, stderr=None if not args.quiet else subprocess.PIPE,
                             text=True)
    if args.quiet and res.returncode != 0 and res.stderr:
        sys.stderr.write(res.stderr)
    if res.returncode != 0:
        print(f"yade_cases: error: yade exited with status {res.returncode} (log: {work / 'yade.log'})",
              file=sys.stderr)
    return res.returncode


def run_particles(jobs, threads: int = 1, quiet: bool = True, timeout: float | None = None) -> None:
    """Runs particles scenes in YADE, all in one YADE process (yade_cases/particles_case.py):
    jobs = [(SCENE, OUT.h5, [key=value, ...]), ...]; existing outputs are replaced.
    Raises SceneRefused (its message a full line, naming the file) before YADE
    starts, or RuntimeError when YADE fails."""
    yade = shutil.which("yade")
    if yade is None:
        raise RuntimeError("`yade` is not on PATH (apt-get install yade; scripts/setup.sh)")
    resolved = []
    for scene, out, sets in jobs:  # every scene checked before anything is written
        try:
            ini = load_initial(scene, sets, extra_sets=["contact.law=viscel"])
            if ini.kind != "particles":
                raise SceneRefused(f"\"{ini.kind}\": not a particles scene", key="scene.kind")
            refuse_unrepresentable(ini)
        except SceneRefused as exc:
            raise SceneRefused(refusal_message(exc, scene, sets)) from None
        resolved.append((scene, Path(out).resolve(), sets, ini))  # yade runs from the repository root
    args = []
    for scene, out, sets, ini in resolved:
        work = Path(str(out) + ".yade")
        write_workdir(work, ini, {"quiet": quiet, "threads": threads, "scene_path": str(scene), "sets": list(sets)})
        if out.exists():
            out.unlink()
        args += [str(work), str(out)]
    log_path = Path(args[0]) / "yade.log"
    cmd = [yade, "-n", "-x", f"-j{max(1, threads)}", str(HERE / "particles_case.py")] + args
    env = dict(os.environ, OMP_NUM_THREADS=str(max(1, threads)))
    with open(log_path, "w") as log:
        res = subprocess.run(cmd, cwd=ROOT, env=env, stdout=log, stderr=subprocess.PIPE, text=True, timeout=timeout)
    if res.returncode != 0:
        raise RuntimeError(f"yade exited with status {res.returncode} (log: {log_path}): {res.stderr[-2000:]}")
    if not quiet and res.stderr:
        sys.stderr.write(res.stderr)


if __name__ == "__main__":
    sys.exit(main())
