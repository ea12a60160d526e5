#!/usr/bin/python3
"""Whether two builds of the native engine compute the same bits.

    scripts/same_bits.py BIN_A BIN_B [-o DIR] [--keep]

Runs every model the shipped scenes can select (the drum's three laws with
periodic and capped ends, the shaken box's laws, integrators and walls, the
particle scenes) for a short stretch through its most violent phase, with
each binary, on one thread and on two, and compares every dataset of the two
outputs bit for bit (NaNs equal). A change to the engine that is meant to
leave the physics alone (a refactor) must print "same" for every case. Exit
status 0 when all cases agree, 1 otherwise.
"""
import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DRUM = ROOT / "scenes" / "drum" / "A.toml"
BOX = ROOT / "scenes" / "box" / "f3.0_big.toml"

# (name, scene, --set options). The drum: the collapse from the lattice and
# the first third of a rotation; the box: half a second of settling and half
# a second of shaking.
DRUM_RUN = ["run.rotations=0.3", "run.snapshot_every=0.1", "run.profile_every=0.1"]
BOX_RUN = ["run.settle=0.5", "run.duration=0.5"]


def cases():
    out = []
    for law in ("rapaport", "linear", "viscel"):
        for ends in ("periodic", "capped"):
            out.append((f"drum-{law}-{ends}", DRUM, [f"contact.law={law}", f"drum.ends={ends}", *DRUM_RUN]))
    for law, dampings in (("poeschel_herrmann", ("normal", "literal")), ("viscel", ("normal",))):
        for damping in dampings:
            for integ in ("default", "gear"):
                for walls in ("particles", "smooth"):
                    sets = [f"contact.law={law}", f"contact.damping={damping}", f"box.walls={walls}", *BOX_RUN]
                    if integ == "gear":
                        sets += ["integrator.kind=gear", "integrator.dt=5e-5"]
                    out.append((f"box-{law}-{damping}-{integ}-{walls}", BOX, sets))
    for scene in sorted((ROOT / "scenes" / "impacts").glob("*.toml")):
        out.append((f"particles-{scene.stem}", scene, []))
    return out


def datasets(path):
    items = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                items[name] = obj[()]
        f.visititems(visit)
    return items


def same(a, b):
    if isinstance(a, np.ndarray) and a.dtype.kind == "f":
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    return np.array_equal(a, b)


def compare(pa, pb):
    """The datasets that differ, and the largest difference of each."""
    da, db = datasets(pa), datasets(pb)
    diffs = []
    for name in sorted(set(da) | set(db)):
        if name not in da or name not in db:
            diffs.append(f"{name}: only in {'A' if name in da else 'B'}")
        elif not same(da[name], db[name]):
            a, b = np.asarray(da[name]), np.asarray(db[name])
            if a.shape == b.shape and a.dtype.kind == "f":
                diffs.append(f"{name}: max |A - B| = {np.nanmax(np.abs(a - b)):.3g}")
            else:
                diffs.append(f"{name}: differs")
    return diffs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bin_a")
    ap.add_argument("bin_b")
    ap.add_argument("-o", "--output", help="directory for the outputs (default: a temporary one)")
    ap.add_argument("--threads", default="1,2", help="thread counts, comma-separated")
    args = ap.parse_args()
    work = Path(args.output) if args.output else Path(tempfile.mkdtemp(prefix="same_bits_"))
    work.mkdir(parents=True, exist_ok=True)
    bad = 0
    for name, scene, sets in cases():
        for threads in args.threads.split(","):
            outs, errors = [], []
            for tag, binary in (("A", args.bin_a), ("B", args.bin_b)):
                out = work / f"{name}-{threads}t-{tag}.h5"
                cmd = [binary, "run", str(scene), "-o", str(out), "--force", "-q", "--threads", threads,
                       "--checkpoint-every", "0", *sum((["--set", s] for s in sets), [])]
                p = subprocess.run(cmd, capture_output=True, text=True)
                # A run that stops (unstable, a grain out of the box) keeps what
                # it wrote; both builds must stop alike, with the same message.
                errors.append((p.returncode, [ln for ln in p.stderr.splitlines() if ln.startswith("error")]))
                outs.append(out)
            diffs = compare(*outs)
            if errors[0] != errors[1]:
                diffs.append(f"exit: A {errors[0]}, B {errors[1]}")
            bad += bool(diffs)
            print(f"{name:45s} {threads}t  {'same' if not diffs else 'DIFFERENT'}", flush=True)
            for d in diffs:
                print(f"    {d}")
    print(f"{bad} case(s) differ" if bad else "all cases give the same bits")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
