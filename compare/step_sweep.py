"""The scenes' observables against the time step, and where each method
fails (docs/speed_accuracy.md, docs/stability.md).

    /usr/bin/python3 -m compare step-sweep -o DIR [--part accuracy|stability|all] [--engines ...]

Accuracy: each method (native laws and integrators, LAMMPS, YADE) runs a short
drum (drum #A's law and geometry at L = 32, 6 rotations: the surface slope)
and the box at 3.2 Hz (8 s: the convective flux Phi_max and the bed height)
over a ladder of time steps and several seeds. The converged reference of a
method is its own smallest step (mean over the seeds); the error of a step is
the distance of its seed mean from it. Cost is the run's CPU seconds
(getrusage of the engine's process tree) per simulated rotation or second, so
it does not depend on what else the machine runs.

Stability: one seed, short runs, the step doubled until the method fails,
also against a physical parameter (drum: rotation rate toward centrifuging;
box: stiffness and shaking frequency). A failure is what the engine reported
(the native engine stops with a message naming the step, the particle and the
cause) or, where an engine went on, what its output shows: non-finite values
or particles outside the container ("silent").

Each run is cached in DIR/runs under its parameters; an interrupted sweep
resumes. DIR/step_sweep.json holds every number; the PNGs go to DIR.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._common import clean_json

ROOT = Path(__file__).resolve().parents[1]
PY = "/usr/bin/python3"

DRUM_SCENE = "scenes/drum/A.toml"
BOX_SCENE = "scenes/box/f3.0_big.toml"
DRUM_BASE = ["drum.length=32", "run.snapshot_every=0.4", "run.profile_every=0.25"]
DRUM_PARAMS = {"bands.final_window": 2.0, "bands.early_window": 2.0}
BOX_DT = 5e-5  # the paper's step (Poeschel and Herrmann 1995)
DRUM_DT = 0.005

# method -> (scene kind, engine, overrides)
METHODS = {
    "drum native rapaport": ("drum", "native", ['contact.law="rapaport"']),
    "drum native linear": ("drum", "native", ['contact.law="linear"']),
    "drum native viscel": ("drum", "native", ['contact.law="viscel"']),
    "drum lammps": ("drum", "lammps", []),
    "drum yade": ("drum", "yade", []),
    "box native gear": ("box", "native", ['integrator.kind="gear"']),
    "box native leapfrog": ("box", "native", ['integrator.kind="leapfrog"']),
    "box native viscel": ("box", "native", ['contact.law="viscel"', 'integrator.kind="leapfrog"']),
    "box lammps": ("box", "lammps", []),
    "box yade": ("box", "yade", []),
}

# Steps of the accuracy ladder (the smallest is the reference), seeds per engine.
DRUM_STEPS = [0.00125, 0.0025, 0.005, 0.01, 0.02]
BOX_STEPS = [BOX_DT * f for f in (0.5, 1, 2, 4, 8)]
SEEDS = {"native": [1, 2, 3], "lammps": [1, 2, 3], "yade": [1]}
# YADE is 30 times slower than the others on the drum: its ladder is shorter.
ENGINE_STEPS = {("drum", "yade"): [0.0025, 0.005, 0.01, 0.02], ("box", "yade"): [BOX_DT * f for f in (0.5, 1, 2, 4)]}

# Tolerances of docs/tolerances.md (the cross-engine ones): the error a step
# may add to an observable.
TOLERANCES = {"slope_deg": ("abs", 3.0), "phi_max": ("rel", 0.25), "bed_height": ("abs", 0.5)}
OBSERVABLES = {"drum": ["slope_deg"], "box": ["phi_max", "bed_height"]}


@dataclass
class Run:
    method: str
    dt: float
    seed: int
    sets: list
    part: str                      # "accuracy" or "stability"
    param: tuple = ("", None)      # stability: (scene key, value)
    extra: dict = field(default_factory=dict)

    @property
    def kind(self):
        return METHODS[self.method][0]

    @property
    def engine(self):
        return METHODS[self.method][1]

    @property
    def scene(self):
        return DRUM_SCENE if self.kind == "drum" else BOX_SCENE

    def all_sets(self):
        return [*self.sets, *METHODS[self.method][2], f"integrator.dt={self.dt!r}", f"particles.seed={self.seed}"]

    def key(self):
        text = (ROOT / self.scene).read_text()
        h = hashlib.sha256(json.dumps({"engine": self.engine, "scene": text, "sets": self.all_sets()},
                                      sort_keys=True).encode()).hexdigest()[:16]
        return f"{self.method.replace(' ', '_')}_{self.dt:.3g}_s{self.seed}_{h}"


def accuracy_runs(engines):
    runs = []
    for m, (kind, engine, _) in METHODS.items():
        if engine not in engines:
            continue
        steps = ENGINE_STEPS.get((kind, engine), DRUM_STEPS if kind == "drum" else BOX_STEPS)
        sets = [*DRUM_BASE, "run.rotations=6"] if kind == "drum" else ["run.duration=8", "shaking.frequency=3.2"]
        for dt in steps:
            for seed in SEEDS[engine]:
                runs.append(Run(m, dt, seed, sets, "accuracy"))
    return runs


def ladder(base, factors):
    return [base * f for f in factors]


def stability_runs(engines):
    """Seed 1, the step doubled from the reference step up."""
    runs = []
    drum_ladder = ladder(DRUM_DT, (0.5, 1, 2, 4, 8, 16, 32))
    box_ladder = ladder(BOX_DT, (1, 2, 4, 8, 16, 32, 64))
    for m, (kind, engine, _) in METHODS.items():
        if engine not in engines:
            continue
        if kind == "drum":
            base = [*DRUM_BASE, "run.rotations=1"]
            # Rotation rate: Omega = 0.5 is the paper's (Froude number Omega^2 (D/2) / g = 0.4
            # with g = 5); from Omega = 0.79 (Froude 1) the wall holds the grains (centrifuging).
            omegas = [0.5, 1.0, 2.0, 4.0] if engine == "native" else [0.5]
            for om in omegas:
                for dt in drum_ladder:
                    runs.append(Run(m, dt, 1, [*base, f"drum.omega={om}"], "stability", ("drum.omega", om)))
        else:
            base = ["run.settle=1.0", "run.duration=1.0", "shaking.frequency=3.0"]
            for dt in box_ladder:
                runs.append(Run(m, dt, 1, base, "stability", ("", None)))
            if engine == "native" and m != "box native viscel":
                for y in [3e7, 3e8]:
                    for dt in box_ladder:
                        runs.append(Run(m, dt, 1, [*base, f"contact.young={y:g}"], "stability", ("contact.young", y)))
                for f in [10.0, 30.0]:
                    for dt in box_ladder:
                        sets = ["run.settle=1.0", "run.duration=1.0", f"shaking.frequency={f}"]
                        runs.append(Run(m, dt, 1, sets, "stability", ("shaking.frequency", f)))
    return runs


# ---------------------------------------------------------------- running


def command(run, out):
    sets = [a for s in run.all_sets() for a in ("--set", s)]
    scene = str(ROOT / run.scene)
    if run.engine == "native":
        binary = os.environ.get("GRANULAR_BIN", str(ROOT / "build" / "granular"))
        return [binary, "run", scene, "-o", str(out), "--threads", "1", "-q", *sets]
    return [PY, "-m", f"{run.engine}_cases", "run", scene, "-o", str(out), "-q", *sets]


def execute(run, outdir, timeout=3600.0):
    """Run once (cached); returns the metadata: CPU seconds, status, message."""
    runs_dir = Path(outdir) / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    key = run.key()
    meta_path = runs_dir / f"{key}.json"
    if meta_path.exists():
        return json.loads(meta_path.read_text())
    out = runs_dir / f"{key}.h5"
    for p in (out, Path(str(out) + ".ckpt")):
        if p.exists():
            p.unlink()
    cmd = command(run, out)
    t0 = time.monotonic()
    # Engines report on stderr; LAMMPS's errors are in its log, read by classify().
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        err = (err or "") + f"\ntimed out after {timeout:.0f} s"
    # CPU time of the engine and everything it started (YADE runs as a child).
    ru = _children_cpu()
    meta = {"command": cmd, "returncode": proc.returncode, "wall_seconds": time.monotonic() - t0,
            "cpu_seconds": ru, "stderr_tail": (err or "")[-1500:], "path": str(out)}
    meta_path.write_text(json.dumps(meta, indent=1))
    return meta


_cpu_seen = [0.0]


def _children_cpu():
    """CPU seconds of the children reaped since the last call."""
    import resource
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = r.ru_utime + r.ru_stime
    d = total - _cpu_seen[0]
    _cpu_seen[0] = total
    return d


# ---------------------------------------------------------------- what a run shows


def classify(run, meta):
    """'ok' or the failure: (status, detail)."""
    err = meta.get("stderr_tail") or ""
    # LAMMPS writes its ERROR lines to its log (OUT.lammps/log.lammps), not to the screen.
    lmp_log = Path(str(meta.get("path", "")) + ".lammps") / "log.lammps"
    if meta["returncode"] != 0 and lmp_log.exists():
        err = "\n".join([ln for ln in lmp_log.read_text(errors="replace").splitlines() if "ERROR" in ln] + [err])
    last = [ln for ln in err.strip().splitlines() if ln.strip()]
    errs = [ln for ln in last if ln.lower().startswith(("error", "lammps error", "runtimeerror"))]
    if errs and "lost atoms" in errs[-1].lower():
        return "lost particles", errs[-1]
    msg = (errs or last or [""])[-1]
    if meta["returncode"] != 0:
        low = err.lower()
        if "unstable" in low and ("non-finite" in low):
            return "non-finite", msg
        # (runs before 2026-11-21 stopped at a move of skin/2: "neighbour list allows")
        if "unstable" in low and ("smallest diameter" in low or "neighbour list allows" in low):
            return "too fast for the step", msg
        if "unstable" in low and "without a source" in low:
            return "energy rising", msg
        if "overlap" in low:
            return "deep overlap", msg
        if "outside" in low or "escaped" in low or "left the" in low or "flying" in low:
            return "escaped", msg
        if "lost atoms" in low:
            return "lost particles", msg
        if "nan" in low or "inf" in low:
            return "non-finite", msg
        if "timed out" in low:
            return "timeout", msg
        return "failed", msg
    # The engine finished: check its output for what it did not report.
    try:
        x, walls = final_positions(meta["path"], run.kind)
    except Exception as e:  # unreadable output is a failure
        return "unreadable output", str(e)
    if not np.all(np.isfinite(x)):
        return "silent non-finite", "the output holds non-finite positions"
    if run.kind == "drum":
        r = np.hypot(x[:, 0], x[:, 2])
        if np.any(r > 8.0 + 1.0):  # outside the drum (D = 16) by more than a diameter
            return "silent escape", f"{int(np.sum(r > 9.0))} particles outside the drum"
    elif walls.size:
        # Outside the walls of particles (which move with the box) by more than a wall particle.
        lo, hi = walls.min(axis=0), walls.max(axis=0)
        out = (x[:, 0] < lo[0] - 2) | (x[:, 0] > hi[0] + 2) | (x[:, 1] < lo[1] - 2)
        if np.any(out):
            return "silent escape", f"{int(np.sum(out))} grains outside the box"
    return "ok", ""


def final_positions(path, kind):
    """The last frame's grain positions and, for the box, its wall particles' (species 2)."""
    from .reader import open_h5
    with open_h5(path) as h5:
        pos = h5["frames/position"]
        n = pos.shape[0]
        sp = h5["frames/species"][n - 1]
        x = pos[n - 1]
    if kind == "drum":
        return x, np.empty((0, 3))
    return x[sp != 2], x[sp == 2]


def observables(run, meta):
    from .validate import box_observables, drum_observables
    if run.kind == "drum":
        o = drum_observables(meta["path"], DRUM_PARAMS)
        return {"slope_deg": o["slope_deg"]}
    o = box_observables(meta["path"])
    return {"phi_max": o["phi_max"], "bed_height": o["bed_height"]}


def sim_units(run):
    """Simulated rotations (drum) or seconds of shaking plus settling (box) of a run."""
    s = {k: v for k, v in (x.split("=", 1) for x in run.sets)}
    if run.kind == "drum":
        return float(s["run.rotations"])
    return float(s.get("run.duration", 60)) + float(s.get("run.settle", 2.0))


# ---------------------------------------------------------------- the sweep


def sweep(outdir, parts=("accuracy", "stability"), engines=("native", "lammps", "yade"), log=print,
          cached_only=False):
    outdir = Path(outdir)
    result = {"accuracy": [], "stability": []}
    todo = []
    if "accuracy" in parts:
        todo += accuracy_runs(engines)
    if "stability" in parts:
        todo += stability_runs(engines)
    # Stability runs stop early on failure; stop a ladder at its second failure.
    failed_at = {}
    t0 = time.monotonic()
    for k, run in enumerate(todo):
        lad = (run.method, run.part, run.param)
        if run.part == "stability" and failed_at.get(lad, 0) >= 2:
            continue
        if cached_only and not (outdir / "runs" / f"{run.key()}.json").exists():
            continue
        meta = execute(run, outdir)
        status, detail = classify(run, meta)
        row = {"method": run.method, "kind": run.kind, "engine": run.engine, "dt": run.dt, "seed": run.seed,
               "param": run.param[0], "value": run.param[1], "status": status, "detail": detail,
               "cpu_seconds": meta["cpu_seconds"], "units": sim_units(run),
               "cpu_per_unit": meta["cpu_seconds"] / sim_units(run)}
        if status == "ok" and run.part == "accuracy":
            try:
                row.update(observables(run, meta))
            except Exception as e:
                row.update(status="analysis failed", detail=str(e))
        if status != "ok":
            failed_at[lad] = failed_at.get(lad, 0) + 1
        result[run.part].append(row)
        log(f"[{k + 1}/{len(todo)}] {run.part} {run.method} dt={run.dt:.3g} seed {run.seed}"
            f"{' ' + run.param[0] + '=' + str(run.param[1]) if run.param[0] else ''}: {status}"
            f" ({meta['cpu_seconds']:.1f} CPU s; {time.monotonic() - t0:.0f} s elapsed)")
    result["summary"] = summarise(result["accuracy"])
    (outdir / "step_sweep.json").write_text(json.dumps(clean_json(result), indent=1))
    plot(result, outdir)
    return result


def summarise(rows):
    """Per method and step: seed means, the error against the method's smallest step, the cost."""
    out = {}
    for m in sorted({r["method"] for r in rows}):
        mine = [r for r in rows if r["method"] == m]
        kind = mine[0]["kind"]
        steps = sorted({r["dt"] for r in mine})
        per = []
        for dt in steps:
            rs = [r for r in mine if r["dt"] == dt]
            ok = [r for r in rs if r["status"] == "ok"]
            # Cost from the runs that finished (a failed run stops early and costs little).
            e = {"dt": dt, "runs": len(rs), "ok": len(ok),
                 "cpu_per_unit": float(np.mean([r["cpu_per_unit"] for r in (ok or rs)])),
                 "failures": sorted({r["status"] for r in rs if r["status"] != "ok"})}
            for obs in OBSERVABLES[kind]:
                v = [r[obs] for r in ok if r.get(obs) is not None and np.isfinite(r[obs])]
                e[obs] = float(np.mean(v)) if v else None
                e[obs + "_se"] = float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else None
            per.append(e)
        ref = per[0]
        for e in per:
            within = e["ok"] == e["runs"]
            for obs in OBSERVABLES[kind]:
                if e[obs] is None or ref[obs] is None:
                    e[obs + "_error"] = None
                    within = False
                    continue
                err = abs(e[obs] - ref[obs])
                mode, tol = TOLERANCES[obs]
                if mode == "rel":
                    err = err / abs(ref[obs]) if ref[obs] else float("inf")
                e[obs + "_error"] = err
                # The statistical part: standard error of the difference of two seed means.
                se = math.hypot(e.get(obs + "_se") or 0.0, ref.get(obs + "_se") or 0.0)
                e[obs + "_error_se"] = se / abs(ref[obs]) if mode == "rel" and ref[obs] else se
                within = within and err <= tol
            e["within_tolerance"] = within
        ok_steps = [e for e in per if e["within_tolerance"]]
        cheapest = min(ok_steps, key=lambda e: e["cpu_per_unit"]) if ok_steps else None
        out[m] = {"kind": kind, "steps": per, "reference_dt": ref["dt"],
                  "cheapest_within_tolerance": cheapest["dt"] if cheapest else None,
                  "cheapest_cpu_per_unit": cheapest["cpu_per_unit"] if cheapest else None}
    return out


def stability_limits(rows):
    """Per method and parameter value: the largest step that ran and the first failure above it."""
    out = []
    keys = sorted({(r["method"], r["param"], r["value"] if r["value"] is not None else -1) for r in rows})
    for m, p, v in keys:
        rs = sorted([r for r in rows if r["method"] == m and r["param"] == p
                     and (r["value"] if r["value"] is not None else -1) == v], key=lambda r: r["dt"])
        ok = [r["dt"] for r in rs if r["status"] == "ok"]
        bad = [r for r in rs if r["status"] != "ok"]
        first_bad = min(bad, key=lambda r: r["dt"]) if bad else None
        out.append({"method": m, "param": p, "value": None if v == -1 else v,
                    "largest_stable_dt": max(ok) if ok else None,
                    "first_failure_dt": first_bad["dt"] if first_bad else None,
                    "failure": first_bad["status"] if first_bad else None,
                    "message": first_bad["detail"] if first_bad else None})
    return out


# ---------------------------------------------------------------- figures

COLOURS = {"native rapaport": "C0", "native linear": "C1", "native viscel": "C2", "lammps": "C3", "yade": "C4",
           "native gear": "C0", "native leapfrog": "C1"}


def pareto(points):
    """Indices of the (cost, error) points no other point beats in both."""
    idx = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], float("inf")
    for i in idx:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def plot(result, outdir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    summ = result["summary"]
    for kind, obs_list, unit in (("drum", ["slope_deg"], "rotation"), ("box", ["phi_max", "bed_height"], "s")):
        ms = [m for m, s in summ.items() if s["kind"] == kind]
        if not ms:
            continue
        fig, axes = plt.subplots(1, len(obs_list), figsize=(6.2 * len(obs_list), 4.6), squeeze=False)
        for ax, obs in zip(axes[0], obs_list):
            pts = []
            for m in ms:
                short = m.split(" ", 1)[1]
                # Steps at which every seed ran (a step where some failed is in the stability map).
                es = [e for e in summ[m]["steps"][1:] if e.get(obs + "_error") is not None and e["ok"] == e["runs"]]
                if not es:
                    continue
                x = [e["cpu_per_unit"] for e in es]
                y = [max(e[obs + "_error"], 1e-4) for e in es]
                se = [e.get(obs + "_error_se") or 0.0 for e in es]
                ax.errorbar(x, y, yerr=[np.minimum(se, np.array(y) * 0.999), se], fmt="o-", capsize=2,
                            color=COLOURS.get(short), label=short)
                for e, xi, yi in zip(es, x, y):
                    ax.annotate(f"{e['dt']:.2g}", (xi, yi), fontsize=7, xytext=(3, 3), textcoords="offset points")
                    pts.append((xi, yi))
            if pts:
                fr = [pts[i] for i in pareto(pts)]
                ax.plot([p[0] for p in fr], [p[1] for p in fr], "k--", lw=0.8, label="Pareto front")
            mode, tol = TOLERANCES[obs]
            ax.axhline(tol, color="grey", ls=":", label=f"tolerance ({tol:g}{'' if mode == 'abs' else ' relative'})")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(f"CPU seconds per simulated {unit} (one core)")
            ax.set_ylabel(f"|{obs}(dt) - {obs}(smallest dt)|" + (" / reference" if mode == "rel" else ""))
            ax.set_title(f"{kind}: {obs} against cost (labels: dt; bars: seed standard error)", fontsize=9)
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(Path(outdir) / f"step_{kind}.png", dpi=110)
        plt.close(fig)
    if result["stability"]:
        plot_stability(result["stability"], outdir)


STATUS_COLOURS = {"ok": "#4caf50", "too fast for the step": "#ff9800", "energy rising": "#ffc107",
                  "non-finite": "#f44336", "deep overlap": "#9c27b0", "escaped": "#3f51b5",
                  "lost particles": "#00bcd4", "silent non-finite": "#000000", "silent escape": "#795548",
                  "failed": "#9e9e9e", "timeout": "#607d8b", "unreadable output": "#e91e63"}


def plot_stability(rows, outdir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    for kind in ("drum", "box"):
        rs = [r for r in rows if r["kind"] == kind]
        if not rs:
            continue
        lines = sorted({(r["method"], r["param"], r["value"] if r["value"] is not None else 0) for r in rs})
        steps = sorted({r["dt"] for r in rs})
        fig, ax = plt.subplots(figsize=(1.1 * len(steps) + 4.5, 0.42 * len(lines) + 1.6))
        seen = set()
        for y, (m, p, v) in enumerate(lines):
            for r in rs:
                if r["method"] == m and r["param"] == p and (r["value"] if r["value"] is not None else 0) == v:
                    x = steps.index(r["dt"])
                    ax.add_patch(plt.Rectangle((x - 0.45, y - 0.4), 0.9, 0.8, color=STATUS_COLOURS.get(r["status"], "k")))
                    seen.add(r["status"])
        ax.set_xlim(-0.6, len(steps) - 0.4)
        ax.set_ylim(-0.6, len(lines) - 0.4)
        ax.set_xticks(range(len(steps)))
        ax.set_xticklabels([f"{s:.3g}" for s in steps], rotation=30)
        ax.set_yticks(range(len(lines)))
        ax.set_yticklabels([f"{m.split(' ', 1)[1]}" + (f", {p.split('.')[-1]}={v:g}" if p else "") for m, p, v in lines],
                           fontsize=8)
        ax.set_xlabel("time step" + (" (drum units)" if kind == "drum" else " (s)"))
        ax.set_title(f"{kind}: outcome per time step (blank: not run, the ladder stopped after two failures)")
        ax.legend(handles=[Patch(color=STATUS_COLOURS.get(s, "k"), label=s) for s in sorted(seen)],
                  fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
        fig.tight_layout()
        fig.savefig(Path(outdir) / f"stability_{kind}.png", dpi=110)
        plt.close(fig)


def markdown(result):
    """The tables of docs/speed_accuracy.md and docs/stability.md."""
    lines = []
    summ = result.get("summary", {})
    if summ:
        lines += ["| method | dt | runs ok | CPU s per unit | " + " | ".join(
            f"{o} (error)" for o in ("slope_deg", "phi_max", "bed_height")) + " | within tolerance |",
            "|---|---|---|---|---|---|---|---|"]
        for m, s in summ.items():
            for e in s["steps"]:
                cells = []
                for o in ("slope_deg", "phi_max", "bed_height"):
                    if o not in e or e[o] is None:
                        cells.append("")
                        continue
                    err = e.get(o + "_error")
                    cells.append(f"{e[o]:.3g} ({err:.2g})" if err is not None else f"{e[o]:.3g}")
                ref = " (ref.)" if e["dt"] == s["reference_dt"] else ""
                lines.append(f"| {m} | {e['dt']:.3g}{ref} | {e['ok']}/{e['runs']} | {e['cpu_per_unit']:.3g} | "
                             + " | ".join(cells) + f" | {'yes' if e['within_tolerance'] else 'no'} |")
        lines += ["", "| method | cheapest dt within tolerance | CPU s per unit there |", "|---|---|---|"]
        for m, s in summ.items():
            c = s["cheapest_within_tolerance"]
            lines.append(f"| {m} | {c:.3g} | {s['cheapest_cpu_per_unit']:.3g} |" if c is not None else f"| {m} | none | |")
    if result.get("stability"):
        lines += ["", "| method | parameter | largest stable dt | first failure | how it fails |", "|---|---|---|---|---|"]
        for r in stability_limits(result["stability"]):
            par = f"{r['param']} = {r['value']:g}" if r["param"] else "scene's own"
            dt_ok = f"{r['largest_stable_dt']:.3g}" if r["largest_stable_dt"] is not None else "none"
            dt_bad = f"{r['first_failure_dt']:.3g}" if r["first_failure_dt"] is not None else "none in the ladder"
            how = f"{r['failure']}: {r['message'][:160]}" if r["failure"] else ""
            lines.append(f"| {r['method']} | {par} | {dt_ok} | {dt_bad} | {how.replace('|', '/')} |")
    return "\n".join(lines)
