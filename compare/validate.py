"""Cross-engine validation: one scene through every engine and set-up, one
analysis, a verdict with numbers (rules: docs/tolerances.md).

    /usr/bin/python3 -m compare validate --suite quick|full -o DIR

Each run is cached in DIR/runs under a hash of the engine, the scene file's
text and the overrides: a rerun reuses finished runs, so an interrupted suite
resumes where it stopped. A cached run is reused only while the scene still
resolves to what it ran (`granular info --json`, defaults included): a changed
default in the engine makes it stale, and it runs again. A run is written to a temporary name and renamed
when its engine exits cleanly, so a half-written file is never reused.
DIR/report.json holds every number, DIR/report.html the page (report_html.py).
Exit status 1 when a gating comparison disagrees.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._common import clean_json

ROOT = Path(__file__).resolve().parents[1]
PY = "/usr/bin/python3"

# ---------------------------------------------------------------- rows

# row -> (engine, overrides). The drum's LAMMPS and YADE cases map Rapaport's
# law themselves (linear, then YADE's law); the box's use the paper's law and
# YADE's law with the same coefficients (docs/model_mapping.md).
DRUM_ROWS = {
    "native-paper": ("native", ["contact.law=\"rapaport\""]),
    "native-linear": ("native", ["contact.law=\"linear\""]),
    "lammps": ("lammps", []),
    "native-viscel": ("native", ["contact.law=\"viscel\""]),
    "yade": ("yade", []),
}
BOX_ROWS = {
    # the paper's law and its Gear predictor-corrector at the paper's step, pinned
    # so that a suite running the other rows at another step keeps it
    "native-paper": ("native", ["integrator.kind=\"gear\"", "integrator.dt=5e-5"]),
    "native-verlet": ("native", ["integrator.kind=\"verlet\""]),
    "lammps": ("lammps", []),  # gran/hooke is the paper's law exactly; velocity Verlet
    "native-viscel": ("native", ["contact.law=\"viscel\"", "integrator.kind=\"verlet\""]),
    "yade": ("yade", []),  # leapfrog
}
# (a, b, gating): gating pairs run the same model and integrator in two engines.
# The drum's native-viscel - yade pair is not gating: YADE's wall is a polygon of
# facets, not the smooth cylinder (docs/tolerances.md, Changes).
DRUM_PAIRS = [("native-linear", "lammps", True), ("native-viscel", "yade", False),
              ("native-paper", "native-linear", False), ("native-paper", "native-viscel", False)]
BOX_PAIRS = [("native-verlet", "lammps", True), ("native-viscel", "yade", True),
             ("native-paper", "native-verlet", False), ("native-verlet", "native-viscel", False)]

# Absolute tolerances of docs/tolerances.md (kind "abs" or "rel" to the mean of the two rows).
TOLERANCES = {
    "slope_deg": ("abs", 3.0),
    "bands_final": ("abs", 2.0),
    "formation_rotations": ("abs", 5.0),
    "phi_max": ("rel", 0.25),
    "bed_height": ("abs", 0.5),
}


@dataclass
class Case:
    name: str
    kind: str            # "drum" or "box"
    scene: str           # path relative to the repository
    sets: list
    seeds: list
    rows: list
    frequencies: list = field(default_factory=list)  # box: one variant per frequency
    params: dict = field(default_factory=dict)       # drum: observe() parameters
    timeout: float = 7200.0
    # engine -> seeds, for an engine too slow to run every seed (the rest run `seeds`)
    engine_seeds: dict = field(default_factory=dict)

    def variants(self):
        if self.kind == "box":
            return [(f"{f:g}Hz", [f"shaking.frequency={f}"]) for f in self.frequencies]
        return [("", [])]


SUITES = {
    "quick": [
        # The quick suite compares the engines at the papers' steps (pinned: the
        # defaults are the cheaper steps of docs/speed_accuracy.md), where the
        # tolerances of docs/tolerances.md were set.
        Case("drum_short", "drum", "scenes/drum/A.toml",
             ["drum.length=32", "run.rotations=6", "run.snapshot_every=0.4", "run.profile_every=0.25",
              "integrator.dt=0.005"],
             [1, 2, 3], list(DRUM_ROWS), params={"bands.final_window": 2.0, "bands.early_window": 2.0},
             timeout=1800),
        Case("box", "box", "scenes/box/f3.0_big.toml", ["run.duration=8", "integrator.dt=5e-5"], [1, 2, 3],
             list(BOX_ROWS),
             frequencies=[2.6, 3.2], timeout=1800),
    ],
    "full": [
        # The drum at the paper's step (the default is 0.01, docs/speed_accuracy.md).
        Case("drum_A", "drum", "scenes/drum/A.toml",
             ["run.rotations=40", "run.snapshot_every=2", "run.profile_every=0.25", "integrator.dt=0.005"],
             [1, 2, 3], list(DRUM_ROWS)),
        # Six packings per frequency where a run costs a minute or two; YADE's
        # box runs take about four and a half minutes each, so YADE runs packings 1-3.
        # Every row but native-paper runs at dt = 2e-4, inside every observable's
        # tolerance in the step sweep (docs/speed_accuracy.md); native-paper keeps
        # the paper's Gear at 5e-5, so the pair native-paper - native-verlet
        # measures the step's effect on the rise fraction itself.
        Case("box", "box", "scenes/box/f3.0_big.toml", ["run.duration=60", "integrator.dt=2e-4"],
             [1, 2, 3, 4, 5, 6], list(BOX_ROWS),
             frequencies=[2.6, 2.8, 3.0, 3.2], engine_seeds={"yade": [1, 2, 3]}),
    ],
}

# ---------------------------------------------------------------- running


def granular_bin():
    return Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))


@dataclass
class Job:
    case: Case
    row: str
    variant: str
    seed: int
    engine: str
    sets: list
    key: str
    path: Path

    @property
    def label(self):
        v = f" {self.variant}" if self.variant else ""
        return f"{self.case.name}{v} {self.row} seed {self.seed}"

    def command(self, out):
        sets = [a for s in self.sets for a in ("--set", s)]
        scene = str(ROOT / self.case.scene)
        if self.engine == "native":
            return [str(granular_bin()), "run", scene, "-o", str(out), "--threads", "1", "-q", *sets]
        return [PY, "-m", f"{self.engine}_cases", "run", scene, "-o", str(out), "-q", *sets]


def jobs_of(suite, outdir, rows=None, cases=None):
    rows_of = {"drum": DRUM_ROWS, "box": BOX_ROWS}
    jobs = []
    for case in [c for c in SUITES[suite] if cases is None or c.name in cases]:
        text = (ROOT / case.scene).read_text()
        for variant, vsets in case.variants():
            for row in [r for r in case.rows if rows is None or r in rows]:
                engine, rsets = rows_of[case.kind][row]
                for seed in case.engine_seeds.get(engine, case.seeds):
                    sets = [*case.sets, *vsets, *rsets, f"particles.seed={seed}"]
                    key = hashlib.sha256(json.dumps({"engine": engine, "scene": text, "sets": sets},
                                                    sort_keys=True).encode()).hexdigest()[:16]
                    path = Path(outdir) / "runs" / f"{case.name}_{row}_{variant or 'x'}_s{seed}_{key}.h5"
                    jobs.append(Job(case, row, variant, seed, engine, sets, key, path))
    return jobs


def resolved_scene(job):
    """The scene as the engines will run it: every key, defaults included
    (`granular info --json` with the job's overrides), without the derived counts."""
    cmd = [str(granular_bin()), "info", str(ROOT / job.case.scene), "--json"]
    for s in job.sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {r.stderr.strip()}")
    scene = json.loads(r.stdout)
    scene.pop("derived", None)
    return scene


# Scene keys added to the engine after runs were cached, with the value that
# reproduces a run made before the key existed (as kKeysAddedLater in
# native/src/app/main.cpp does for checkpoints): a cached resolution without
# the key still matches a scene that resolves it to this value.
KEYS_ADDED_LATER = {("box", "walls"): "particles", ("particles", "rotation"): True}


# Scene keys an engine does not read, per engine and scene kind: a change in
# them does not change its run. LAMMPS and YADE shake the box with their own
# integrators (velocity Verlet, leapfrog) whatever integrator.kind says.
NOT_READ = {("lammps", "box"): [("integrator", "kind")], ("yade", "box"): [("integrator", "kind")]}


def same_resolution(stored, current, ignore=()):
    """Whether a cached run's resolved scene is the one the scene resolves to now
    (the keys in `ignore` left out of both)."""
    if stored == current:
        return True
    stored = {t: dict(v) if isinstance(v, dict) else v for t, v in stored.items()}
    current = {t: dict(v) if isinstance(v, dict) else v for t, v in current.items()}
    for table, key in ignore:
        stored.get(table, {}).pop(key, None)
        current.get(table, {}).pop(key, None)
    for (table, key), value in KEYS_ADDED_LATER.items():
        if key not in stored.get(table, {}) and current.get(table, {}).get(key) == value:
            stored.setdefault(table, {})[key] = value
    return stored == current


def same_run_elsewhere(job, resolved):
    """A finished run of the same case, row, variant and seed cached under
    another key (another scene text or overrides) whose scene resolved to
    exactly this one: e.g. a default pinned in the overrides at the value the
    run had. Returns its .h5 path or None."""
    stem = job.path.stem
    prefix = stem[:stem.rindex("_") + 1]
    for meta_path in sorted(job.path.parent.glob(prefix + "*.json")):
        h5 = meta_path.with_suffix(".h5")
        if h5 == job.path or not h5.exists() or h5.stem[len(prefix):].count("_"):
            continue
        meta = json.loads(meta_path.read_text())
        if meta.get("returncode") == 0 and "resolved_scene" in meta and same_resolution(
                meta["resolved_scene"], resolved, NOT_READ.get((job.engine, job.case.kind), ())):
            return h5
    return None


def run_job(job, log=print):
    """Run one job unless its output exists and still matches the scene as it
    resolves now; returns its metadata dict."""
    meta_path = job.path.with_suffix(".json")
    resolved = resolved_scene(job)
    if not job.path.exists() and (twin := same_run_elsewhere(job, resolved)) is not None:
        os.link(twin, job.path)
        meta = json.loads(twin.with_suffix(".json").read_text()) | {"resolved_scene": resolved,
                                                                    "same_as": twin.name}
        meta_path.write_text(json.dumps(meta, indent=1))
        log(f"  {job.label}: the cached {twin.name} ran this very scene; reused")
    if job.path.exists() and meta_path.exists():
        meta = json.loads(meta_path.read_text())
        if "resolved_scene" not in meta:  # cached before the check existed: adopt today's resolution
            meta["resolved_scene"] = resolved
            meta_path.write_text(json.dumps(meta, indent=1))
        if same_resolution(meta["resolved_scene"], resolved, NOT_READ.get((job.engine, job.case.kind), ())):
            return meta | {"cached": True}
        stale = job.path.with_name(job.path.stem + ".stale.h5")
        os.replace(job.path, stale)
        meta_path.unlink()
        log(f"  stale: {job.label} ran a scene that now resolves differently (a default changed); "
            f"moved to {stale.name}, running again")
    job.path.parent.mkdir(parents=True, exist_ok=True)
    tmp = job.path.with_name(job.path.stem + ".partial.h5")
    if tmp.exists():
        tmp.unlink()
    cmd = job.command(tmp)
    t0 = time.monotonic()
    rc, err, cpu = run_timed(cmd, job.case.timeout)
    wall = time.monotonic() - t0
    meta = {"label": job.label, "command": cmd, "wall_seconds": wall, "cpu_seconds": cpu, "returncode": rc,
            "resolved_scene": resolved}
    if rc != 0:
        lines = [ln for ln in err.strip().splitlines() if ln.strip()]
        meta["error"] = " | ".join(lines[-3:]) if lines else f"exit status {rc}"
        log(f"  FAILED {job.label}: {meta['error']}")
        return meta | {"cached": False}
    os.replace(tmp, job.path)
    meta_path.write_text(json.dumps(meta, indent=1))
    return meta | {"cached": False}


def run_timed(cmd, timeout):
    """Runs cmd; returns (exit status, the tail of its stderr, CPU seconds).
    The CPU seconds are the process's own user+system time and its reaped
    children's (os.wait4), so a run's speed does not depend on what else the
    machine ran beside it, as wall-clock time would."""
    with tempfile.TemporaryFile("w+") as errf:
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=errf, text=True, cwd=ROOT)
        timed_out = threading.Event()
        timer = threading.Timer(timeout, lambda: (timed_out.set(), p.kill()))
        timer.start()
        try:
            _, status, ru = os.wait4(p.pid, 0)
        finally:
            timer.cancel()
        p.returncode = os.waitstatus_to_exitcode(status)  # reaped here; tell Popen
        errf.seek(0)
        err = errf.read()[-2000:]
    rc = p.returncode
    if timed_out.is_set():
        rc, err = -1, f"timed out after {timeout:.0f} s"
    return rc, err, ru.ru_utime + ru.ru_stime


def run_all(jobs, lanes=2, log=print):
    done = [0]
    t0 = time.monotonic()

    def one(job):
        m = run_job(job, log)
        done[0] += 1
        how = "cached" if m.get("cached") else f"{m['wall_seconds']:.0f} s"
        log(f"[{done[0]}/{len(jobs)}] {job.label}: {how}  ({time.monotonic() - t0:.0f} s elapsed)")
        return m

    # The slow engines first, so the lanes finish together.
    order = sorted(range(len(jobs)), key=lambda i: {"yade": 0, "lammps": 1}.get(jobs[i].engine, 2))
    metas = [None] * len(jobs)
    with ThreadPoolExecutor(max_workers=lanes) as ex:
        for i, m in zip(order, ex.map(lambda i: one(jobs[i]), order)):
            metas[i] = m
    return metas

# ---------------------------------------------------------------- observables of one run


def steps_and_particles(path):
    from .reader import open_h5
    with open_h5(path) as h5:
        st = h5["frames/step"][()]
        n = h5["frames/id"].shape[1]
    return int(st[-1]) if st.size else 0, int(n)


def drum_observables(path, params):
    from .observe import observe
    d = observe(path, params)
    s = d.get("surface", {})
    return {
        "slope_deg": s.get("slope_angle_deg"),
        "bands_final": d["bands"]["final"],
        "formation_rotations": d["formation"].get("formation_time_rotations"),
        "surface_x": s.get("x"), "surface_height": s.get("height"),
        "coulomb_at_cap": (d.get("coulomb") or {}).get("all_at_cap"),
    }


def box_observables(path):
    from .box import BigDiskHeight, ConvectiveFlux, bed_height, read_trace
    from .coulomb import BOX_SPECIES, CoulombCap, read_census
    from .box import Shaker
    from .reader import read_run
    run = read_run(path)
    fl = ConvectiveFlux().compute(run)
    out = {"phi_max": fl.phi_max, "convecting": fl.depth is not None, "bed_height": bed_height(run),
           "phi_heights": fl.heights, "phi": fl.phi, "phi_se": fl.phi_se}
    if read_trace(run) is not None:
        h = BigDiskHeight().compute(run).as_dict()
        out["rose"] = bool(h.get("reached_top"))
        out["height_t"], out["height"] = h["cycle_time_s"], h["cycle_mean_height"]
    if read_census(path) is not None:
        out["coulomb_at_cap"] = CoulombCap(Shaker(run).settle, BOX_SPECIES).compute(path).all_at_cap
    return out

# ---------------------------------------------------------------- agreement rules


def summary(values):
    v = [x for x in values if x is not None and not (isinstance(x, float) and math.isnan(x))]
    n = len(v)
    return {"n": n, "undefined": len(values) - n, "values": values,
            "mean": float(np.mean(v)) if n else None,
            "sd": float(np.std(v, ddof=1)) if n > 1 else (0.0 if n == 1 else None)}


def welch(a, b, confidence=0.95):
    """Difference of means b - a and its two-sided Welch interval."""
    from scipy.stats import t as student
    d = b["mean"] - a["mean"]
    va = a["sd"] ** 2 / a["n"]
    vb = b["sd"] ** 2 / b["n"]
    se = math.sqrt(va + vb)
    if se == 0.0:
        return d, 0.0, (d, d)
    dof = (va + vb) ** 2 / ((va ** 2 / (a["n"] - 1) if a["n"] > 1 else 0) + (vb ** 2 / (b["n"] - 1) if b["n"] > 1 else 0)
                            or 1e-300)
    q = float(student.ppf(0.5 + confidence / 2, max(dof, 1.0)))
    return d, se, (d - q * se, d + q * se)


def compare_scalar(name, a, b, confidence=0.95):
    """Agreement of two rows on one scalar observable (docs/tolerances.md)."""
    kind, tol = TOLERANCES[name]
    out = {"observable": name, "a": {k: a[k] for k in ("mean", "sd", "n", "undefined")},
           "b": {k: b[k] for k in ("mean", "sd", "n", "undefined")}}
    if a["undefined"] != b["undefined"]:
        return out | {"agree": False, "reason": f"undefined in {a['undefined']} vs {b['undefined']} seeds"}
    if a["n"] == 0:
        return out | {"agree": True, "reason": "undefined in every seed of both rows"}
    d, se, ci = welch(a, b, confidence)
    tol_abs = tol if kind == "abs" else tol * 0.5 * abs(a["mean"] + b["mean"])
    consistent = ci[0] <= 0.0 <= ci[1]
    within = abs(d) <= tol_abs
    reason = []
    if not consistent:
        reason.append(f"{100 * confidence:.4g}% interval of the difference [{ci[0]:.3g}, {ci[1]:.3g}] excludes 0")
    if not within:
        reason.append(f"|difference| {abs(d):.3g} > tolerance {tol_abs:.3g}")
    return out | {"difference": d, "se": se, "ci": list(ci), "confidence": confidence, "tolerance": tol_abs, "consistent": consistent,
                  "within_tolerance": within, "agree": consistent and within, "reason": "; ".join(reason)}


def binomial(k, n):
    from .box import onset_fraction
    frac, lo, hi = onset_fraction([True] * k + [False] * (n - k))
    return {"k": k, "n": n, "fraction": frac, "ci95": [lo, hi]}


def compare_binomial(name, a, b):
    overlap = a["ci95"][0] <= b["ci95"][1] and b["ci95"][0] <= a["ci95"][1]
    return {"observable": name, "a": a, "b": b, "agree": overlap,
            "reason": "" if overlap else "95% Clopper-Pearson intervals do not overlap"}

# ---------------------------------------------------------------- the suite


def analyse(suite, jobs, metas):
    cases = {}
    for job, meta in zip(jobs, metas):
        c = cases.setdefault(job.case.name, {"kind": job.case.kind, "scene": job.case.scene, "sets": job.case.sets,
                                             "seeds": job.case.seeds, "variants": {}})
        v = c["variants"].setdefault(job.variant, {})
        r = v.setdefault(job.row, {"runs": []})
        # Speed from CPU time; runs cached before it was recorded fall back to wall-clock time.
        seconds = meta.get("cpu_seconds") or meta.get("wall_seconds")
        run = {"seed": job.seed, "path": str(job.path), "wall_seconds": meta.get("wall_seconds"),
               "cpu_seconds": meta.get("cpu_seconds"),
               "ok": meta.get("returncode") == 0, "error": meta.get("error"), "cached": meta.get("cached")}
        if run["ok"]:
            try:
                obs = (drum_observables(job.path, job.case.params) if job.case.kind == "drum"
                       else box_observables(job.path))
                steps, n = steps_and_particles(job.path)
                run.update(obs, particles=n, steps=steps,
                           particle_steps_per_second=n * steps / seconds if seconds else None,
                           timed_by="cpu" if meta.get("cpu_seconds") else "wall")
            except Exception as e:  # an analysis failure is a failure of the run, reported
                run.update(ok=False, error=f"analysis: {e}")
        r["runs"].append(run)
    comparisons, failures, pending = [], [], []
    for name, c in cases.items():
        pairs = DRUM_PAIRS if c["kind"] == "drum" else BOX_PAIRS
        scalars = ["slope_deg", "bands_final", "formation_rotations"] if c["kind"] == "drum" else ["bed_height", "phi_max"]
        for vname, rows in c["variants"].items():
            for row, r in rows.items():
                r["failed_runs"] = [x["seed"] for x in r["runs"] if not x["ok"]]
                r["summary"] = {k: summary([x.get(k) for x in r["runs"] if x["ok"]]) for k in scalars}
                if c["kind"] == "box":
                    conv = [x["convecting"] for x in r["runs"] if x["ok"]]
                    r["convection"] = binomial(sum(conv), len(conv)) if conv else None
                    rose = [x["rose"] for x in r["runs"] if x["ok"] and "rose" in x]
                    r["rise"] = binomial(sum(rose), len(rose)) if rose else None
                rates = [x["particle_steps_per_second"] for x in r["runs"] if x.get("particle_steps_per_second")]
                r["speed"] = float(np.median(rates)) if rates else None
            for a, b, gating in pairs:
                if a not in rows or b not in rows:
                    continue
                ra, rb = rows[a], rows[b]
                base = {"case": name, "variant": vname, "a_row": a, "b_row": b, "gating": gating}
                if ra["failed_runs"] or rb["failed_runs"]:
                    comparisons.append(base | {"observable": "runs", "agree": False,
                                               "reason": f"failed runs: {a} {ra['failed_runs']}, {b} {rb['failed_runs']}"})
                    continue
                for k in scalars:
                    if k == "phi_max" and not all(x["convection"]["k"] == x["convection"]["n"] for x in (ra, rb)):
                        continue  # Phi_max is compared at a convecting frequency: every packing of both rows convects
                    pending.append((len(comparisons), base, k, ra["summary"][k], rb["summary"][k]))
                    comparisons.append(None)
                if c["kind"] == "box":
                    comparisons.append(base | compare_binomial("convection", ra["convection"], rb["convection"]))
                    if ra.get("rise") and rb.get("rise"):
                        comparisons.append(base | compare_binomial("rise", ra["rise"], rb["rise"]))
        if c["kind"] == "box" and len(c["variants"]) > 1:
            c["thresholds"] = box_thresholds(c)
    # 95 % family-wise over the gating scalar comparisons (Bonferroni), and the
    # same per-comparison level for the reported model comparisons.
    m = max(1, sum(1 for _, base, *_ in pending if base["gating"]))
    confidence = 1.0 - 0.05 / m
    for i, base, k, a, b in pending:
        comparisons[i] = base | compare_scalar(k, a, b, confidence)
    for cmp in comparisons:
        if cmp["gating"] and not cmp["agree"]:
            failures.append(cmp)
    return {"suite": suite, "created": time.strftime("%Y-%m-%d %H:%M:%S"), "rules": "docs/tolerances.md",
            "gating_scalar_comparisons": m, "per_comparison_confidence": confidence,
            "tolerances": TOLERANCES, "cases": cases, "comparisons": comparisons,
            "verdict": "pass" if not failures else "fail",
            "failures": [f"{f['case']} {f['variant']} {f['a_row']} vs {f['b_row']}: {f['observable']}: {f['reason']}"
                         for f in failures]}


def box_thresholds(c):
    """Convection onset (and rise threshold) per row over the frequency grid."""
    from .box import onset_threshold
    out = {}
    rows = sorted({r for v in c["variants"].values() for r in v})
    for row in rows:
        fr, conv, rise, n = [], [], [], []
        for vname, v in c["variants"].items():
            if row not in v or v[row]["convection"] is None:
                continue
            fr.append(float(vname.rstrip("Hz")))
            conv.append(v[row]["convection"]["k"])
            n.append(v[row]["convection"]["n"])
            rise.append(v[row]["rise"]["k"] if v[row].get("rise") else 0)
        if fr:
            out[row] = {"convection": onset_threshold(fr, conv, n), "rise": onset_threshold(fr, rise, n)}
    return out


def validate(suite, outdir, lanes=2, rows=None, cases=None, log=print):
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    unknown = sorted(set(cases or []) - {c.name for c in SUITES[suite]})
    if unknown:
        raise SystemExit(f"validate --cases: no case {', '.join(unknown)} in suite {suite!r} "
                         f"(cases: {', '.join(c.name for c in SUITES[suite])})")
    jobs = jobs_of(suite, outdir, rows, cases)
    log(f"validate --suite {suite}: {len(jobs)} runs in {outdir / 'runs'} ({lanes} lanes)")
    metas = run_all(jobs, lanes, log)
    report = analyse(suite, jobs, metas)
    (outdir / "report.json").write_text(json.dumps(clean_json(report), indent=1))
    from .report_html import write_report
    write_report(report, outdir)
    log(f"report: {outdir / 'report.html'}  verdict: {report['verdict']}")
    for f in report["failures"]:
        log(f"  DISAGREE {f}")
    return report
