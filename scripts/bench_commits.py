#!/usr/bin/python3
"""Whether one commit's native engine is slower than another's.

    scripts/bench_commits.py OLD NEW [--rounds N] [--instructions] [--dir DIR]

Builds each commit's engine (Release, through ccache where it is installed)
from `git archive` into DIR/<hash>/, then times the cases below on one thread
in interleaved rounds, each round in a fresh random order, so that the
machine's load and clock changes fall on both builds alike. Each case runs
with the scene files of its own commit. Prints, per case, NEW's rate over
OLD's: the median of the rounds' ratios, the geometric mean with its 95 %
t interval and the range. --instructions adds the instructions each build
executes on a shorter run of every case (callgrind; deterministic, so one
run a build), the figure that separates a real change from the rounds' noise.
The figures in docs/speed_accuracy.md ("Floating-point contraction") come
from this script.
"""
import argparse
import json
import os
import random
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parent.parent

# (case, scene, timed run, callgrind run, --set options). The box's leapfrog
# is its default integrator under every name it has had.
CASES = [
    ("drum-rapaport", "scenes/drum/A.toml", ["--rotations", "2", "--settle", "0.5"],
     ["--rotations", "0.3", "--settle", "0.1"], []),
    ("drum-linear", "scenes/drum/A.toml", ["--rotations", "2", "--settle", "0.5"],
     ["--rotations", "0.3", "--settle", "0.1"], ["contact.law=linear"]),
    ("box-leapfrog", "scenes/box/f3.0_big.toml", ["--seconds", "3", "--settle", "1"],
     ["--seconds", "0.3", "--settle", "0.2"], []),
    ("box-gear", "scenes/box/f3.0_big.toml", ["--seconds", "3", "--settle", "1"],
     ["--seconds", "0.3", "--settle", "0.2"], ["integrator.kind=gear"]),
]


def build(commit: str, top: Path) -> Path:
    """The commit's engine, built once under top/<hash>; returns its tree."""
    sha = subprocess.run(["git", "rev-parse", "--short", commit], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.strip()
    tree = top / sha
    binary = tree / "build" / "granular"
    if binary.exists():
        return tree
    (tree / "src").mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "archive", sha], cwd=ROOT, check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tree / "src")], input=archive, check=True)
    launcher = ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"] if shutil.which("ccache") else []
    subprocess.run(["cmake", "-S", str(tree / "src"), "-B", str(tree / "build"), "-DCMAKE_BUILD_TYPE=Release",
                    "-DPython3_EXECUTABLE=/usr/bin/python3", *launcher], check=True, capture_output=True)
    env = dict(os.environ, CCACHE_BASEDIR=str(tree), CCACHE_NOHASHDIR="1")
    subprocess.run(["cmake", "--build", str(tree / "build"), "-j", str(os.cpu_count()), "--target", "granular"],
                   check=True, capture_output=True, env=env)
    return tree


def command(tree: Path, scene: str, length: list[str], sets: list[str]) -> list[str]:
    return [str(tree / "build" / "granular"), "bench", scene, "--threads", "1", "--json", *length,
            *sum((["--set", s] for s in sets), [])]


def rate(tree: Path, case) -> float:
    _, scene, timed, _, sets = case
    p = subprocess.run(command(tree, scene, timed, sets), cwd=tree / "src", check=True, capture_output=True,
                       text=True)
    return float(json.loads(p.stdout)[0]["particle_steps_per_second"])


def instructions(tree: Path, case) -> int:
    """Instructions of the timed child process (the largest of the processes
    `granular bench` runs), under callgrind."""
    _, scene, _, short, sets = case
    out = tree / "callgrind.%p.out"
    p = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        *command(tree, scene, short, sets)], cwd=tree / "src", capture_output=True, text=True,
                       env=dict(os.environ, GOMP_SPINCOUNT="1000"))
    if p.returncode != 0:
        raise RuntimeError(f"callgrind of {case[0]} failed:\n{p.stderr[-2000:]}")
    for f in tree.glob("callgrind.*.out"):
        f.unlink()
    return max(int(n.replace(",", "")) for n in re.findall(r"Collected : ([0-9,]+)", p.stderr))


def summary(new: list[float], old: list[float]) -> str:
    r = np.log(np.array(new) / np.array(old))
    n = len(r)
    half = stats.t.ppf(0.975, n - 1) * r.std(ddof=1) / np.sqrt(n) if n > 1 else float("nan")
    return (f"{np.exp(np.median(r)):.3f} | {np.exp(r.mean()):.3f} [{np.exp(r.mean() - half):.3f}, "
            f"{np.exp(r.mean() + half):.3f}] | {np.exp(r.min()):.2f}–{np.exp(r.max()):.2f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rounds", type=int, default=12, help="interleaved rounds (default 12)")
    ap.add_argument("--instructions", action="store_true", help="also count instructions under callgrind")
    ap.add_argument("--dir", type=Path, default=Path("/tmp/bench_commits"), help="where the builds go")
    a = ap.parse_args()
    trees = {"old": build(a.old, a.dir), "new": build(a.new, a.dir)}
    rates = {(c[0], k): [] for c in CASES for k in trees}
    for r in range(a.rounds):
        order = [(c, k) for c in CASES for k in trees]
        random.shuffle(order)
        for c, k in order:
            rates[(c[0], k)].append(rate(trees[k], c))
        print(f"round {r + 1} of {a.rounds}", file=sys.stderr, flush=True)
    print(f"{trees['new'].name} over {trees['old'].name}, one thread, {a.rounds} interleaved rounds\n")
    head = "| case | median ratio | mean [95 %] | range | new rate (particle-steps/s) |"
    if a.instructions:
        head += " instructions new/old |"
    print(head)
    print("|---" * (head.count("|") - 1) + "|")
    for c in CASES:
        row = (f"| {c[0]} | {summary(rates[(c[0], 'new')], rates[(c[0], 'old')])} | "
               f"{np.median(rates[(c[0], 'new')]):.3g} |")
        if a.instructions:
            row += f" {instructions(trees['new'], c) / instructions(trees['old'], c):.3f} |"
        print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
