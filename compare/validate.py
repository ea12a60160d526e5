"""Cross-engine validation: one scene through every engine and set-up, one
analysis, a verdict with numbers (rules: docs/tolerances.md).

    /usr/bin/python3 -m compare validate --suite quick|full -o DIR

Each run is cached in DIR/runs under a hash of the engine, the scene file's
text and the overrides: a rerun reuses finished runs, so an interrupted suite
resumes where it stopped. A cached run is reused only while the scene still
resolves to what it ran (`granular info --json`, defaults included): a changed
default in the engine makes it stale, and it runs again. A run is written to a temporary name and renamed
when its engine exits cleanly, so a half-written file is never reused. Runs
cached under a row's earlier name are found as well (OLD_ROW_NAMES).
DIR/report.json holds every number, DIR/report.html the page (report_html.py).
Exit status 1 when a gating comparison disagrees.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import resource
import signal
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
    "native-leapfrog": ("native", ["integrator.kind=\"leapfrog\""]),
    "lammps": ("lammps", []),  # gran/hooke is the paper's law exactly; velocity Verlet
    "native-viscel": ("native", ["contact.law=\"viscel\"", "integrator.kind=\"leapfrog\""]),
    "yade": ("yade", []),  # leapfrog
}
# (a, b, gating): gating pairs run the same model and integrator in two engines.
# The drum's native-viscel - yade pair is not gating: YADE's wall is a polygon of
# facets, not the smooth cylinder (docs/tolerances.md, "Which rows are compared").
DRUM_PAIRS = [("native-linear", "lammps", True), ("native-viscel", "yade", False),
              ("native-paper", "native-linear", False), ("native-paper", "native-viscel", False)]
BOX_PAIRS = [("native-leapfrog", "lammps", True), ("native-viscel", "yade", True),
             ("native-paper", "native-leapfrog", False), ("native-leapfrog", "native-viscel", False)]

# Equivalence margins of docs/tolerances.md, each with its physical reason there,
# fixed before the runs. Scalars in their own units; yes/no observables as a
# difference of fractions.
MARGINS = {
    "slope_deg": 1.5,
    "bands_final": 2.0,
    "formation_rotations": 5.0,
    "formed": 0.3,
    "phi_max": 3.6,
    "bed_height": 0.5,
    "top_time_s": 2.0,
    "rose": 0.3,
    "convecting": 0.3,
}
BINARY = {"formed", "rose", "convecting"}
# An observable gates a same-model pair only where the suite's sample size gives
# an engine pair that is truly the same at least this probability of the
# verdict "equivalent" (docs/tolerances.md, "Sample sizes").
POWER = 0.8
# The suite as a whole: engines that are truly the same pass every gating
# comparison with at least this probability (pass_probability), so that a
# failed CI run means a difference, not bad luck (docs/tolerances.md).
SUITE_PASS = 0.9


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
    # variant -> seeds, for a variant whose observables need more runs than `seeds`
    variant_seeds: dict = field(default_factory=dict)
    # engine -> seeds, for an engine too slow to run every seed: a list (these in
    # every variant) or variant -> list; the other engines run the variant's seeds
    engine_seeds: dict = field(default_factory=dict)
    # variant -> observables compared between rows ("" is the drum's one variant)
    compared: dict = field(default_factory=dict)
    # (variant, observable) -> the spread the sample size was designed for, measured
    # before the suite was fixed: the sd of paired differences b_i - a_i for a
    # scalar, the fraction p for a yes/no observable (docs/tolerances.md)
    design: dict = field(default_factory=dict)
    # box: (above, below) variants between which every row must show the big
    # disk's rise threshold
    threshold: tuple = ()
    # observable -> margin, where the case needs its own (docs/tolerances.md)
    margins: dict = field(default_factory=dict)

    def margin(self, observable):
        return self.margins.get(observable, MARGINS[observable])

    def seeds_of(self, variant, engine=None):
        """The seeds an engine runs in a variant."""
        default = self.variant_seeds.get(variant, self.seeds)
        seeds = self.engine_seeds.get(engine, default)
        return seeds.get(variant, default) if isinstance(seeds, dict) else seeds

    def paired_runs(self, variant, row_a, row_b):
        """How many seeds rows a and b share in a variant: the sample size of
        their paired comparison."""
        ea, eb = (ROWS_OF[self.kind][r][0] for r in (row_a, row_b))
        return len(set(self.seeds_of(variant, ea)) & set(self.seeds_of(variant, eb)))

    def variants(self):
        if self.kind == "box":
            return [(f"{f:g}Hz", [f"shaking.frequency={f}"]) for f in self.frequencies]
        return [("", [])]


DRUM_OBSERVABLES = ["slope_deg", "bands_final", "formation_rotations", "formed"]

# The big disk 15 cm above the floor (two to three rows of grains under it
# after settling): at 3.2 Hz the rolls carry it to the top in 5-10 s in every
# packing and engine; at 2.6 Hz, below the convection onset, in none
# (docs/shaken_box.md, "R = 4 cm").
# Twenty packings at 3.2 Hz, where the time to the top needs them; YADE
# runs ten at 3.2 Hz and seven at 2.6 Hz, the fewest that give its pair's
# gating observables there power (docs/tolerances.md, "Sample sizes").
BOX_RISE = Case("box_rise", "box", "scenes/box/f3.0_big.toml", ["run.duration=12", "big.gap=15"],
                list(range(1, 11)), ["native-leapfrog", "lammps", "native-viscel", "yade"],
                frequencies=[2.6, 3.2], timeout=1800,
                variant_seeds={"3.2Hz": list(range(1, 21))},
                engine_seeds={"yade": {"2.6Hz": list(range(1, 8)), "3.2Hz": list(range(1, 11))}},
                compared={"2.6Hz": ["rose", "convecting", "bed_height"],
                          "3.2Hz": ["rose", "convecting", "phi_max", "top_time_s"]},
                design={("2.6Hz", "rose"): 0.0, ("2.6Hz", "convecting"): 0.16, ("2.6Hz", "bed_height"): 0.19,
                        # rose at 3.2 Hz: 786 of the false-alarm study's 800 runs (docs/validation.md)
                        ("3.2Hz", "rose"): 0.98, ("3.2Hz", "convecting"): 1.0, ("3.2Hz", "phi_max"): 2.7,
                        # one run's sd, 1.4 s over the false-alarm study's 800 runs, times
                        # sqrt(2): the packing does not pair the rise times (docs/tolerances.md)
                        ("3.2Hz", "top_time_s"): 2.0},
                threshold=("3.2Hz", "2.6Hz"))

SUITES = {
    "quick": [
        # #A's law and geometry cut to L = 32 (1144 particles), 40 rotations at the
        # default step, twelve seeds: two bands form at rotations 8-33 in native-linear, LAMMPS
        # and the paper's law (docs/tolerances.md, "The quick suite"). YADE's law
        # forms no bands (no Coulomb cap) and its facet wall is not the smooth one:
        # its drum pair is in the full suite only.
        Case("drum_short", "drum", "scenes/drum/A.toml",
             ["drum.length=32", "run.rotations=40", "run.snapshot_every=2", "run.profile_every=0.25"],
             list(range(1, 13)), ["native-paper", "native-linear", "lammps"],
             params={"bands.final_window": 5.0, "bands.early_window": 5.0}, timeout=1800,
             compared={"": DRUM_OBSERVABLES},
             # L = 32 holds one band pair: a pair is the whole pattern (docs/tolerances.md)
             margins={"bands_final": 1.0},
             # slope: one run's sd, 0.84 deg over the false-alarm study's 400 runs,
             # times sqrt(2) (docs/tolerances.md, "Sample sizes")
             design={("", "slope_deg"): 1.2, ("", "bands_final"): 0.85, ("", "formation_rotations"): 8.9,
                     ("", "formed"): 0.88}),
        BOX_RISE,
    ],
    "full": [
        # #A at full length (4664 particles), 40 rotations at the default step
        # (0.01: docs/drum_scenes.md, "Time step"); 48 seeds, what the formation
        # time needs for the suite to pass a correct engine with probability
        # SUITE_PASS (36 give it power 0.80 alone; docs/tolerances.md, "Sample
        # sizes"). YADE's drum pair does not gate (facet wall, no Coulomb cap)
        # and costs about 20 CPU-minutes a run: three seeds show its slope and
        # banding.
        Case("drum_A", "drum", "scenes/drum/A.toml",
             ["run.rotations=40", "run.snapshot_every=2", "run.profile_every=0.25"],
             list(range(1, 49)), list(DRUM_ROWS), engine_seeds={"yade": [1, 2, 3]},
             compared={"": DRUM_OBSERVABLES},
             design={("", "slope_deg"): 0.8, ("", "bands_final"): 2.6, ("", "formation_rotations"): 10.0,
                     ("", "formed"): 1.0}),
        # The box over the frequency grid with the big disk on the floor (the
        # scenes' placement): the rise and convection onsets, Phi(D), the heights.
        # Every row but native-paper at dt = 2e-4, inside every observable's
        # tolerance in the step sweep (docs/speed_accuracy.md); native-paper keeps
        # the paper's Gear at 5e-5, so native-paper - native-leapfrog measures the step.
        # The bed settles before the shaking starts, the same at every frequency:
        # it is compared once.
        Case("box", "box", "scenes/box/f3.0_big.toml", ["run.duration=60", "integrator.dt=2e-4"],
             list(range(1, 9)), list(BOX_ROWS), frequencies=[2.6, 2.8, 3.0, 3.2],
             compared={"2.6Hz": ["rose", "convecting", "bed_height"],
                       **{f: ["rose", "convecting", "phi_max"] for f in ("2.8Hz", "3Hz", "3.2Hz")}},
             design={("2.6Hz", "bed_height"): 0.19, **{(f, "phi_max"): 1.0 for f in ("2.8Hz", "3Hz", "3.2Hz")},
                     ("2.6Hz", "rose"): 0.0, ("2.8Hz", "rose"): 0.2, ("3Hz", "rose"): 0.35, ("3.2Hz", "rose"): 0.45,
                     ("2.6Hz", "convecting"): 0.4, ("2.8Hz", "convecting"): 1.0, ("3Hz", "convecting"): 1.0,
                     ("3.2Hz", "convecting"): 1.0},
             threshold=("3.2Hz", "2.6Hz")),
        # The quick suite's box_rise runs, for each row's rise threshold alone:
        # with the disk on the floor (the case above) the rise within 60 s is a
        # first passage with waiting times of 7-110 s, in about 0.45 of the
        # packings at 3.2 Hz, and eight packings a frequency show the threshold
        # with probability 0.52 only (threshold_design). Here, started 15 cm up,
        # the disk rises at 3.2 Hz in 0.98 of the packings within 12 s and at
        # 2.6 Hz in none: power 1.00 in every row, 45 CPU-minutes. Its
        # pairwise comparisons are the quick suite's; nothing is compared here.
        dataclasses.replace(BOX_RISE, name="box_threshold", compared={},
                            design={k: v for k, v in BOX_RISE.design.items() if k[1] == "rose"}),
    ],
}

# Planted model errors (compare validate --mutants): each changes one thing in
# the native rows of the gating pairs; the suite should call the planted row
# different from the reference engine wherever the error's true effect on an
# observable exceeds its margin. (table.key, factor) multiplies the scene's
# resolved value; (table.key, "=", value) sets it.
MUTANTS = {
    "wall_friction_big_half": ("the big grains' wall sliding friction gamma_s^bw x 0.5",
                               {"drum": [("friction.gamma_s_bw", 0.5)]}),
    "coulomb_half": ("the Coulomb coefficient mu x 0.5",
                     {"drum": [("contact.mu_max", 0.5)], "box": [("contact.mu", 0.5)]}),
    "inertia": ("the moment-of-inertia factor: drum kappa 0.2 -> 0.4; disks 1/2 -> 1/4",
                       {"drum": [("contact.kappa", 2.0)], "box": [("particles.inertia_factor", 0.5)]}),
    "damping_double": ("normal damping x 2", {"drum": [("contact.gamma_n", 2.0)], "box": [("contact.gamma_n", 2.0)]}),
    "wall_friction_off": ("no wall friction", {"drum": [("friction.gamma_s_bw", 0.0), ("friction.gamma_s_sw", 0.0)]}),
    "amplitude_1.8": ("the box's amplitude 2.0 -> 1.8 cm", {"box": [("shaking.amplitude", 0.9)]}),
    "gravity_5pc": ("gravity 5 % too strong", {"drum": [("gravity.g", 1.05)], "box": [("gravity.g", 1.05)]}),
    "omega_0.9": ("the drum's rotation speed x 0.9", {"drum": [("drum.omega", 0.9)]}),
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


ROWS_OF = {"drum": DRUM_ROWS, "box": BOX_ROWS}


def _job(case, row, variant, seed, engine, sets, outdir):
    text = (ROOT / case.scene).read_text()
    key = hashlib.sha256(json.dumps({"engine": engine, "scene": text, "sets": sets},
                                    sort_keys=True).encode()).hexdigest()[:16]
    path = Path(outdir) / "runs" / f"{case.name}_{row}_{variant or 'x'}_s{seed}_{key}.h5"
    return Job(case, row, variant, seed, engine, sets, key, path)


def jobs_of(suite, outdir, rows=None, cases=None):
    jobs = []
    for case in [c for c in SUITES[suite] if cases is None or c.name in cases]:
        for variant, vsets in case.variants():
            for row in [r for r in case.rows if rows is None or r in rows]:
                engine, rsets = ROWS_OF[case.kind][row]
                for seed in case.seeds_of(variant, engine):
                    jobs.append(_job(case, row, variant, seed, engine,
                                     [*case.sets, *vsets, *rsets, f"particles.seed={seed}"], outdir))
    return jobs


def gating_native_rows(case):
    """The native rows of the case's same-model (gating) pairs, with their references."""
    pairs = DRUM_PAIRS if case.kind == "drum" else BOX_PAIRS
    return [(a, b) for a, b, gating in pairs if gating and a in case.rows and b in case.rows]


def mutant_sets(case, row, mutant):
    """The overrides that plant `mutant` in `row` of `case` (values from the
    scene as it resolves with the row's own overrides), or None when the
    mutant does not apply to the case's kind."""
    changes = MUTANTS[mutant][1].get(case.kind)
    if not changes:
        return None
    _, rsets = ROWS_OF[case.kind][row]
    cmd = [str(granular_bin()), "info", str(ROOT / case.scene), "--json"]
    for x in [*case.sets, *rsets]:
        cmd += ["--set", x]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {r.stderr.strip()}")
    scene = json.loads(r.stdout)
    out = []
    for key, factor in changes:
        table, name = key.split(".")
        out.append(f"{key}={float(scene[table][name]) * factor!r}")
    return out


def mutant_jobs(suite, outdir, mutants, cases=None):
    """Every mutant planted in every gating native row of the suite's cases,
    over the case's seeds and variants; row labels ROW+MUTANT."""
    jobs = []
    for case in [c for c in SUITES[suite] if (cases is None or c.name in cases) and any(c.compared.values())]:
        for row, _ in gating_native_rows(case):
            for mutant in mutants:
                msets = mutant_sets(case, row, mutant)
                if msets is None:
                    continue
                engine, rsets = ROWS_OF[case.kind][row]
                for variant, vsets in case.variants():
                    for seed in case.seeds_of(variant, engine):
                        jobs.append(_job(case, f"{row}+{mutant}", variant, seed, engine,
                                         [*case.sets, *vsets, *rsets, *msets, f"particles.seed={seed}"], outdir))
    return jobs


FALSE_ALARM_SEED0 = 10000


def false_alarm_seeds(case, variant, repeat, group):
    """Fresh seeds for the false-alarm study: repeat r, group 0 or 1, as many as
    the case's native rows run in the variant, disjoint from each other and
    from the suite's seeds."""
    n = len(case.seeds_of(variant))
    first = FALSE_ALARM_SEED0 + (2 * repeat + group) * n
    return list(range(first, first + n))


def false_alarm_jobs(suite, outdir, repeats, cases=None):
    """The native rows of the gating pairs run on 2 x repeats groups of fresh
    seeds; row labels ROW@rREPEAT.GROUP."""
    jobs = []
    for case in [c for c in SUITES[suite] if cases is None or c.name in cases]:
        for row, _ in gating_native_rows(case):
            engine, rsets = ROWS_OF[case.kind][row]
            for rep in range(repeats):
                for group in (0, 1):
                    for variant, vsets in case.variants():
                        for seed in false_alarm_seeds(case, variant, rep, group):
                            jobs.append(_job(case, f"{row}@r{rep}.{group}", variant, seed, engine,
                                             [*case.sets, *vsets, *rsets, f"particles.seed={seed}"], outdir))
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
KEYS_ADDED_LATER = {("box", "walls"): "particles", ("particles", "rotation"): True,
                    ("run", "final_snapshots"): 0, ("run", "final_snapshot_every"): 5.0}

# Earlier names, for runs cached under them: a row's runs are also looked for
# under its earlier names (OLD_ROW_NAMES), and a cached resolution that holds
# a value's earlier name matches the scene that resolves to its present one
# (OLD_VALUES). A suite directory made before keeps its runs.
OLD_ROW_NAMES = {"native-leapfrog": ["native-verlet"]}
OLD_VALUES = {("integrator", "kind"): {"verlet": "leapfrog"}}


def old_row_names(row):
    """The earlier names of a row label, planted errors (ROW+MUTANT) and
    false-alarm groups (ROW@rR.G) included."""
    cut = min([i for i in (row.find("+"), row.find("@")) if i >= 0], default=len(row))
    return [old + row[cut:] for old in OLD_ROW_NAMES.get(row[:cut], [])]


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
    for (table, key), names in OLD_VALUES.items():
        value = stored.get(table, {}).get(key)
        if isinstance(value, str) and value in names:
            stored[table][key] = names[value]
    return stored == current


def same_run_elsewhere(job, resolved):
    """A finished run of the same case, row, variant and seed cached under
    another key (another scene text or overrides), or under one of the row's
    earlier names (OLD_ROW_NAMES), whose scene resolved to exactly this one:
    e.g. a default pinned in the overrides at the value the run had. Returns
    its .h5 path or None."""
    tail = f"_{job.variant or 'x'}_s{job.seed}_"
    for row in [job.row, *old_row_names(job.row)]:
        prefix = f"{job.case.name}_{row}{tail}"
        for meta_path in sorted(job.path.parent.glob(prefix + "*.json")):
            h5 = meta_path.with_suffix(".h5")
            if h5 == job.path or not h5.exists() or h5.stem[len(prefix):].count("_"):
                continue
            meta = json.loads(meta_path.read_text())
            if meta.get("returncode") == 0 and "resolved_scene" in meta and same_resolution(
                    meta["resolved_scene"], resolved, NOT_READ.get((job.engine, job.case.kind), ())):
                return h5
    return None


def write_meta(path, meta):
    """A run's metadata, replacing the previous in one rename (a copy taken
    while the suite runs, scripts/campaign_store.sh, never sees half of it)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(meta, indent=1))
    os.replace(tmp, path)


def run_job(job, log=print):
    """Run one job unless its output exists and still matches the scene as it
    resolves now; returns its metadata dict."""
    meta_path = job.path.with_suffix(".json")
    resolved = resolved_scene(job)
    if not job.path.exists() and (twin := same_run_elsewhere(job, resolved)) is not None:
        os.link(twin, job.path)
        meta = json.loads(twin.with_suffix(".json").read_text()) | {"resolved_scene": resolved,
                                                                    "same_as": twin.name}
        write_meta(meta_path, meta)
        log(f"  {job.label}: the cached {twin.name} ran this very scene; reused")
    if meta_path.exists() and (job.path.exists() or kept_observables(job, json.loads(meta_path.read_text()))):
        meta = json.loads(meta_path.read_text())
        if "resolved_scene" not in meta:  # cached before the check existed: adopt today's resolution
            meta["resolved_scene"] = resolved
            write_meta(meta_path, meta)
        if same_resolution(meta["resolved_scene"], resolved, NOT_READ.get((job.engine, job.case.kind), ())):
            return meta | {"cached": True}
        if job.path.exists():
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
    drop_run_companions(tmp)
    write_meta(meta_path, keep_observables(job, meta))
    return meta | {"cached": False}


def drop_run_companions(out):
    """Removes what the native engine writes beside a run's output OUT.h5: its
    final checkpoint (OUT.h5.ckpt, for lengthening a run; the suite never
    does) and its ParaView index (OUT.xdmf, which names the file by the
    temporary name it had while it ran)."""
    Path(str(out) + ".ckpt").unlink(missing_ok=True)
    out.with_suffix(".xdmf").unlink(missing_ok=True)


def yield_like_this_process(pid):
    """Gives the scheduler group of `pid` (started by setsid) this process's
    niceness. Where the kernel groups processes by setsid (autogroups,
    /proc/sys/kernel/sched_autogroup_enabled), niceness ranks a process only
    within its group and the groups share the cores equally: a run in a
    group of its own would take its full share at any niceness, and the full
    suite at nice 19 would not yield to interactive work."""
    try:
        Path(f"/proc/{pid}/autogroup").write_text(str(os.getpriority(os.PRIO_PROCESS, 0)))
    except OSError:  # no autogroups, or not ours to change
        pass


def run_timed(cmd, timeout):
    """Runs cmd; returns (exit status, the tail of its stderr, CPU seconds).

    ``timeout`` is in CPU seconds, for each process of the run (RLIMIT_CPU,
    inherited by the engine the driver starts): a run on a machine that gives
    it a quarter of a core (the full suite at nice 19 beside other jobs) is
    not cut short for being slow, only for computing too long. A run that
    hangs without computing is stopped after ten times ``timeout`` of
    wall-clock time. Either way, and after a normal end, every process the run
    started goes (it runs in a process group of its own), so no engine is
    left running without its driver.
    The CPU seconds are the process's own user+system time and its reaped
    children's (os.wait4), so a run's speed does not depend on what else the
    machine ran beside it, as wall-clock time would."""
    limit = max(1, int(math.ceil(timeout)))

    def kill_group():
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass

    with tempfile.TemporaryFile("w+") as errf:
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=errf, text=True, cwd=ROOT,
                             start_new_session=True)
        # Set before the driver starts its engine (it is still importing).
        resource.prlimit(p.pid, resource.RLIMIT_CPU, (limit, limit + 5))
        yield_like_this_process(p.pid)
        timed_out = threading.Event()
        timer = threading.Timer(10 * timeout, lambda: (timed_out.set(), kill_group()))
        timer.start()
        try:
            _, status, ru = os.wait4(p.pid, 0)
        finally:
            timer.cancel()
            kill_group()
        p.returncode = os.waitstatus_to_exitcode(status)  # reaped here; tell Popen
        errf.seek(0)
        err = errf.read()[-2000:]
    rc = p.returncode
    cpu = ru.ru_utime + ru.ru_stime
    if timed_out.is_set():
        rc, err = -1, f"hung: no end after {10 * timeout:.0f} s of wall-clock time"
    elif rc != 0 and cpu >= limit - 1:  # the engine, or the driver with it, reached RLIMIT_CPU
        rc, err = -1, f"timed out after {timeout:.0f} CPU seconds"
    return rc, err, cpu


# ---------------------------------------------------------------- the native rows on the GPU engine

# The scene kinds whose native runs go to the GPU engine as replicas: the
# drum's and the shaken box's. A box of about a thousand grains alone is too
# small to keep a GPU busy; its replicas make it worth one: one process for a
# row's packings (docs/gpu.md).
REPLICA_KINDS = ("drum", "box")
# The most seeds in one GPU process: 64 copies of #A need about 0.2 GiB.
MAX_REPLICAS = 64


def native_device(choice="auto"):
    """The device for the native rows: `choice`, or for "auto" the GPU engine
    where `granular devices` finds a CUDA device, else the CPU."""
    if choice != "auto":
        return choice
    try:
        r = subprocess.run([str(granular_bin()), "devices", "--json"], capture_output=True, text=True, timeout=60)
        return "gpu" if r.returncode == 0 and json.loads(r.stdout)["gpu"]["available"] else "cpu"
    except (OSError, ValueError, KeyError, subprocess.TimeoutExpired):
        return "cpu"


def replica_batches(jobs, device):
    """The native runs still to be made that can share a GPU process: runs of
    one case, row and variant with the same overrides but the seed, and
    consecutive seeds (replica k runs seed + k); at most MAX_REPLICAS a batch.
    Runs already on disk, or cached under another name (same_run_elsewhere),
    are left to run_job."""
    if device == "cpu":
        return []
    groups = {}
    for job in jobs:
        if job.engine != "native" or job.case.kind not in REPLICA_KINDS or job.path.exists():
            continue
        if same_run_elsewhere(job, resolved_scene(job)) is not None:
            continue
        rest = tuple(x for x in job.sets if not x.startswith("particles.seed="))
        groups.setdefault((job.case.name, job.row, job.variant, rest), []).append(job)
    batches = []
    for group in groups.values():
        group.sort(key=lambda j: j.seed)
        batch = [group[0]]
        for job in group[1:]:
            if job.seed == batch[-1].seed + 1 and len(batch) < MAX_REPLICAS:
                batch.append(job)
            else:
                batches.append(batch)
                batch = [job]
        batches.append(batch)
    return batches


def run_batch(batch, device, log=print):
    """Runs a replica batch in one GPU engine process (granular run --device
    DEVICE --replicas K from the first seed) and files replica k as the k-th
    job's run; returns their metadata dicts."""
    first, k = batch[0], len(batch)
    first.path.parent.mkdir(parents=True, exist_ok=True)
    partial = first.path.with_name(f"{first.path.stem}.partial_x{k}.h5")
    outs = [partial.with_name(f"{partial.stem}_r{r:02d}.h5") for r in range(k)]
    for out in outs:
        out.unlink(missing_ok=True)
    cmd = [*first.command(partial), "--device", device, "--replicas", str(k)]
    resolved = [resolved_scene(job) for job in batch]
    t0 = time.monotonic()
    rc, err, cpu = run_timed(cmd, first.case.timeout * k)
    wall = time.monotonic() - t0
    metas = []
    for r, (job, out) in enumerate(zip(batch, outs)):
        meta = {"label": job.label, "command": cmd, "device": device, "replicas": k, "replica": r,
                "wall_seconds": wall / k, "cpu_seconds": cpu / k, "returncode": rc, "resolved_scene": resolved[r]}
        if rc != 0 or not out.exists():
            drop_run_companions(out)
            lines = [ln for ln in err.strip().splitlines() if ln.strip()]
            meta["returncode"] = rc or 1
            meta["error"] = " | ".join(lines[-3:]) if lines else f"no replica file {out.name}"
            if r == 0:
                log(f"  FAILED {job.label} and its {k - 1} fellow replicas: {meta['error']}")
            metas.append(meta | {"cached": False})
            continue
        os.replace(out, job.path)
        drop_run_companions(out)
        write_meta(job.path.with_suffix(".json"), keep_observables(job, meta))
        metas.append(meta | {"cached": False})
    return metas


def run_all(jobs, lanes=2, log=print, device="cpu"):
    """Runs (or finds in the cache) every job; returns their metadata dicts in
    the jobs' order. With device gpu or gpu-host, the native drum and box runs
    go to the GPU engine as replica batches (replica_batches); the rest as
    usual."""
    done = [0]
    t0 = time.monotonic()
    batches = replica_batches(jobs, device)
    index = {id(job): i for i, job in enumerate(jobs)}
    batched = {id(job) for b in batches for job in b}
    units = batches + [[job] for job in jobs if id(job) not in batched]

    def one(unit):
        ms = run_batch(unit, device, log) if id(unit[0]) in batched else [run_job(unit[0], log)]
        for job, m in zip(unit, ms):
            done[0] += 1
            how = "cached" if m.get("cached") else f"{m['wall_seconds']:.0f} s"
            if m.get("replicas"):
                how += f" (replica {m['replica']} of {m['replicas']} on {m['device']})"
            log(f"[{done[0]}/{len(jobs)}] {job.label}: {how}  ({time.monotonic() - t0:.0f} s elapsed)")
        return ms

    # The slow engines first, so the lanes finish together.
    units.sort(key=lambda u: {"yade": 0, "lammps": 1}.get(u[0].engine, 2))
    metas = [None] * len(jobs)
    with ThreadPoolExecutor(max_workers=lanes) as ex:
        for unit, ms in zip(units, ex.map(one, units)):
            for job, m in zip(unit, ms):
                metas[index[id(job)]] = m
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
    formation = d["formation"].get("formation_time_rotations")
    return {
        "slope_deg": s.get("slope_angle_deg"),
        "bands_final": d["bands"]["final"],
        "formation_rotations": formation,
        "formed": formation is not None,
        "surface_x": s.get("x"), "surface_height": s.get("height"),
        "coulomb_at_cap": (d.get("coulomb") or {}).get("all_at_cap"),
    }


def box_observables(path):
    from .box import BigDiskHeight, ConvectiveFlux, Shaker, bed_height, read_trace
    from .coulomb import BOX_SPECIES, CoulombCap, read_census
    from .reader import read_run
    run = read_run(path)
    fl = ConvectiveFlux().compute(run)
    out = {"phi_max": fl.phi_max, "convecting": fl.depth is not None, "bed_height": bed_height(run),
           "phi_heights": fl.heights, "phi": fl.phi, "phi_se": fl.phi_se}
    if read_trace(run) is not None:
        h = BigDiskHeight().compute(run).as_dict()
        out["rose"] = bool(h.get("reached_top"))
        out["top_time_s"] = h.get("top_crossing_s") if out["rose"] else None
        out["height_t"], out["height"] = h["cycle_time_s"], h["cycle_mean_height"]
    if read_census(path) is not None:
        out["coulomb_at_cap"] = CoulombCap(Shaker(run).settle, BOX_SPECIES).compute(path).all_at_cap
    return out


# A run's observables are kept in its metadata (DIR/runs/X.json) beside the
# analysis that computed them: a hash of that analysis's code (the functions
# above and the modules they use). The suite's verdicts need only these, so a
# run whose output is gone (a suite restored from its metadata alone,
# scripts/campaign_store.sh) still counts while the analysis is unchanged;
# a changed analysis computes them again from the output, or runs again.
ANALYSIS_MODULES = ("observe.py", "bands.py", "profile.py", "spacetime.py", "surface.py", "box.py", "coulomb.py",
                    "reader.py", "_common.py")


@functools.lru_cache(maxsize=1)
def analysis_hash():
    import inspect
    h = hashlib.sha256()
    for f in (drum_observables, box_observables, steps_and_particles):
        h.update(inspect.getsource(f).encode())
    for name in ANALYSIS_MODULES:
        h.update((ROOT / "compare" / name).read_bytes())
    return h.hexdigest()[:16]


def observables_of(job):
    """(observables, steps, particles) of a finished run, from its output."""
    obs = (drum_observables(job.path, job.case.params) if job.case.kind == "drum"
           else box_observables(job.path))
    steps, n = steps_and_particles(job.path)
    return obs, steps, n


def keep_observables(job, meta):
    """meta with the run's observables added (see analysis_hash); unchanged
    where the analysis fails, which the report then gives as the run's error."""
    try:
        obs, steps, n = observables_of(job)
    except Exception:  # reported by _rows_of_case, which computes them again
        return meta
    return meta | {"observables": clean_json({"analysis": analysis_hash(), "params": job.case.params,
                                              "values": obs, "steps": steps, "particles": n})}


def kept_observables(job, meta):
    """(observables, steps, particles) kept in meta by the present analysis
    with the case's present parameters, or None."""
    k = meta.get("observables")
    if not k or k.get("analysis") != analysis_hash() or k.get("params") != clean_json(job.case.params):
        return None
    return k["values"], k["steps"], k["particles"]

# ---------------------------------------------------------------- verdicts (docs/tolerances.md)


def summary(values):
    v = [x for x in values if x is not None and not (isinstance(x, float) and math.isnan(x))]
    n = len(v)
    return {"n": n, "undefined": len(values) - n, "values": values,
            "mean": float(np.mean(v)) if n else None,
            "sd": float(np.std(v, ddof=1)) if n > 1 else (0.0 if n == 1 else None)}


def binomial(k, n):
    """k of n with the fraction's 95 % Clopper-Pearson interval (for display)."""
    from .box import onset_fraction
    frac, lo, hi = onset_fraction([True] * k + [False] * (n - k))
    return {"k": k, "n": n, "fraction": frac, "ci95": [lo, hi]}


def _defined(x):
    return x is not None and not (isinstance(x, float) and math.isnan(x))


def compare_rows(observable, runs_a, runs_b, paired=True, margin=None):
    """Three-way verdict (compare/decision.py) of row b against row a on one
    observable over their successful runs: a yes/no observable by its fractions,
    a scalar by its values, paired by seed (the rows start from the same
    packings) or independent. Returns the decision dict with both rows' summaries."""
    from .decision import verdict_independent, verdict_paired, verdict_proportions
    margin = MARGINS[observable] if margin is None else margin
    if observable in BINARY:
        va = [bool(r[observable]) for r in runs_a if r.get(observable) is not None]
        vb = [bool(r[observable]) for r in runs_b if r.get(observable) is not None]
        sa, sb = binomial(sum(va), len(va)) if va else None, binomial(sum(vb), len(vb)) if vb else None
        res = verdict_proportions(sum(va), len(va), sum(vb), len(vb), margin)
        return res | {"observable": observable, "a": sa, "b": sb, "paired": False}
    sa = summary([r.get(observable) for r in runs_a])
    sb = summary([r.get(observable) for r in runs_b])
    if paired:
        by_seed = {r["seed"]: r.get(observable) for r in runs_a}
        both = [(by_seed[r["seed"]], r.get(observable)) for r in runs_b
                if r["seed"] in by_seed and _defined(by_seed[r["seed"]]) and _defined(r.get(observable))]
        xa = [x for x, _ in both]
        xb = [y for _, y in both]
        res = verdict_paired(xa, xb, margin)
    else:
        res = verdict_independent([x for x in sa["values"] if _defined(x)], [x for x in sb["values"] if _defined(x)],
                                  margin)
    return res | {"observable": observable, "a": sa, "b": sb, "paired": paired}


@functools.lru_cache(maxsize=4096)
def design_power(observable, spread, n, margin=None):
    """Probability that two rows that are truly the same reach "equivalent" on
    `observable` with n runs each, when the runs spread as designed (sd of the
    paired differences, or the fraction p)."""
    from .decision import equivalence_power, proportion_power
    margin = MARGINS[observable] if margin is None else margin
    if n < 2:
        return 0.0
    if observable in BINARY:
        return proportion_power(spread, spread, n, n, margin)
    return equivalence_power(0.0, spread, n, margin, paired=True)


@functools.lru_cache(maxsize=4096)
def required_runs(observable, spread, margin=None, n_max=200):
    """The smallest n with design_power >= POWER (None above n_max)."""
    from .decision import sample_size_for_equivalence
    margin = MARGINS[observable] if margin is None else margin
    if observable not in BINARY:
        return sample_size_for_equivalence(spread, margin, power=POWER, paired=True, n_max=n_max)
    lo, hi = 1, n_max
    if design_power(observable, spread, hi, margin) < POWER:
        return None
    while hi - lo > 1:  # the power of the proportion test rises with n, up to the lattice's wiggles
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if design_power(observable, spread, mid, margin) >= POWER else (mid, hi)
    return hi


def design_of(case, variant, observable, n):
    """The power analysis behind one comparison: margin, designed spread, runs
    required for POWER, runs used, power at those runs, gating or reported."""
    spread = case.design.get((variant, observable))
    if spread is None:
        return {"spread": None, "required": None, "n": n, "power": None, "gating": False,
                "why": "no designed spread: reported"}
    margin = case.margin(observable)
    pw = design_power(observable, float(spread), int(n), margin)
    req = required_runs(observable, float(spread), margin)
    ok = pw >= POWER
    return {"spread": spread, "required": req, "n": n, "power": pw, "gating": ok,
            "why": (f"power {pw:.2f} at n = {n}" if ok else
                    f"power {pw:.2f} < {POWER} at n = {n} (needs {req if req else '> 200'}): reported")}


def threshold_design(case, row):
    """The power analysis behind one row's threshold test: the rise fractions
    the case was designed for above and below the threshold, the runs the row
    makes at each, and the probability that the test shows the threshold
    there; it gates only at POWER or more."""
    above, below = case.threshold
    engine = ROWS_OF[case.kind][row][0]
    pa, pb = case.design.get((above, "rose")), case.design.get((below, "rose"))
    na, nb = len(case.seeds_of(above, engine)), len(case.seeds_of(below, engine))
    if pa is None or pb is None:
        return {"spread": None, "required": None, "n": na + nb, "power": None, "gating": False,
                "why": "no designed rise fractions: reported"}
    from .decision import threshold_power
    pw = threshold_power(float(pa), na, float(pb), nb)
    ok = pw >= POWER
    return {"spread": f"{pa:g}/{pb:g}", "required": None, "n": na + nb, "power": pw, "gating": ok,
            "why": (f"power {pw:.2f} at {na}/{nb} runs" if ok else
                    f"power {pw:.2f} < {POWER} at {na}/{nb} runs (rising in {pa:g} of the runs above): reported")}


def gating_rows_of(case):
    """The rows of the case's same-model (gating) pairs."""
    pairs = DRUM_PAIRS if case.kind == "drum" else BOX_PAIRS
    return [r for r in case.rows if any(g and r in (a, b) for a, b, g in pairs)]


def _rows_of_case(cases, job, meta):
    c = cases.setdefault(job.case.name, {"kind": job.case.kind, "scene": job.case.scene, "sets": job.case.sets,
                                         "seeds": job.case.seeds, "variants": {}, "case": job.case})
    v = c["variants"].setdefault(job.variant, {})
    r = v.setdefault(job.row, {"runs": []})
    # Speed from CPU time; runs cached before it was recorded fall back to wall-clock time.
    seconds = meta.get("cpu_seconds") or meta.get("wall_seconds")
    run = {"seed": job.seed, "path": str(job.path) if job.path.exists() else None,
           "wall_seconds": meta.get("wall_seconds"),
           "cpu_seconds": meta.get("cpu_seconds"),
           "ok": meta.get("returncode") == 0, "error": meta.get("error"), "cached": meta.get("cached")}
    if run["ok"]:
        try:
            kept = kept_observables(job, meta)
            obs, steps, n = kept if kept else observables_of(job)
            run.update(obs, particles=n, steps=steps,
                       particle_steps_per_second=n * steps / seconds if seconds else None,
                       timed_by="cpu" if meta.get("cpu_seconds") else "wall")
        except Exception as e:  # an analysis failure is a failure of the run, reported
            run.update(ok=False, error=f"analysis: {e}")
    r["runs"].append(run)


def _ok(r):
    return [x for x in r["runs"] if x["ok"]]


def _summarise_rows(c):
    case = c["case"]
    for vname, rows in c["variants"].items():
        observables = case.compared.get(vname, [])
        for row, r in rows.items():
            r["failed_runs"] = [x["seed"] for x in r["runs"] if not x["ok"]]
            oks = _ok(r)
            r["summary"] = {k: summary([x.get(k) for x in oks]) for k in observables if k not in BINARY}
            r["fractions"] = {k: binomial(sum(bool(x[k]) for x in oks if x.get(k) is not None),
                                          sum(1 for x in oks if x.get(k) is not None))
                              for k in observables if k in BINARY and any(x.get(k) is not None for x in oks)}
            if c["kind"] == "box":
                conv = [x["convecting"] for x in oks]
                r["convection"] = binomial(sum(conv), len(conv)) if conv else None
                rose = [x["rose"] for x in oks if "rose" in x]
                r["rise"] = binomial(sum(rose), len(rose)) if rose else None
                # the paper: "convection is always present when segregation happens"
                r["rose_without_convection"] = sum(1 for x in oks if x.get("rose") and not x["convecting"])
            rates = [x["particle_steps_per_second"] for x in r["runs"] if x.get("particle_steps_per_second")]
            r["speed"] = float(np.median(rates)) if rates else None


def _pair_comparisons(name, c, a, b, gating_pair, paired=True, label_a=None, label_b=None):
    """Every compared observable of rows a and b in every variant of case c."""
    case = c["case"]
    out = []
    for vname, rows in c["variants"].items():
        if a not in rows or b not in rows:
            continue
        ra, rb = rows[a], rows[b]
        base = {"case": name, "variant": vname, "a_row": label_a or a, "b_row": label_b or b}
        failed = [x["seed"] for x in ra["runs"] + rb["runs"] if not x["ok"]]
        if failed:
            out.append(base | {"observable": "runs", "verdict": "inconclusive", "gating": gating_pair,
                               "why": "failed runs", "reason": f"failed runs: {a} {[x['seed'] for x in ra['runs'] if not x['ok']]}, "
                                                               f"{b} {[x['seed'] for x in rb['runs'] if not x['ok']]}"})
            continue
        n = min(len(ra["runs"]), len(rb["runs"]))
        for k in case.compared.get(vname, []):
            d = design_of(case, vname, k, n)
            res = compare_rows(k, _ok(ra), _ok(rb), paired=paired, margin=case.margin(k))
            gating = gating_pair and d["gating"]
            why = ("same model; " + d["why"]) if gating_pair else "model comparison: reported"
            out.append(base | res | {"gating": gating, "design": d, "why": why})
    return out


def _thresholds(name, c, gating_rows):
    """Per row: does the big disk rise more often above the threshold frequency
    than below it (compare/decision.py: threshold_test)?"""
    from .decision import threshold_test
    case = c["case"]
    if not case.threshold:
        return []
    above, below = case.threshold
    out = []
    va, vb = c["variants"].get(above, {}), c["variants"].get(below, {})
    for row in va:
        # the case's own rows only: a planted error's or a false-alarm group's
        # rows ("row+mutant", "row@rK.G") have their own comparisons
        if row not in vb or row not in ROWS_OF[case.kind]:
            continue
        ra, rb = [x for x in _ok(va[row]) if "rose" in x], [x for x in _ok(vb[row]) if "rose" in x]
        if not ra or not rb:
            continue
        t = threshold_test(sum(x["rose"] for x in ra), len(ra), sum(x["rose"] for x in rb), len(rb))
        d = threshold_design(case, row)
        out.append({"case": name, "row": row, "above": above, "below": below, "same_model_row": row in gating_rows,
                    "gating": row in gating_rows and d["gating"], "design": d} | t)
    return out


def analyse(suite, jobs, metas, mutants=(), false_alarm_repeats=0):
    cases = {}
    for job, meta in zip(jobs, metas):
        _rows_of_case(cases, job, meta)
    comparisons, thresholds = [], []
    mutant_results, false_alarms = [], []
    for name, c in cases.items():
        _summarise_rows(c)
        case = c["case"]
        pairs = DRUM_PAIRS if c["kind"] == "drum" else BOX_PAIRS
        for a, b, gating in pairs:
            comparisons += _pair_comparisons(name, c, a, b, gating)
        thresholds += _thresholds(name, c, set(gating_rows_of(case)))
        if c["kind"] == "box" and len(c["variants"]) > 1:
            c["thresholds"] = box_thresholds(c)
        gate = {(x["variant"], x["a_row"], x["b_row"], x["observable"]): x["gating"] for x in comparisons
                if x["case"] == name}
        for row, ref in gating_native_rows(case):
            for mutant in mutants:
                label = f"{row}+{mutant}"
                if not any(label in rows for rows in c["variants"].values()):
                    continue
                vs_ref = _pair_comparisons(name, c, label, ref, True)
                effect = _pair_comparisons(name, c, row, label, True)
                for x, e in zip(vs_ref, effect):
                    mutant_results.append({
                        "mutant": mutant, "description": MUTANTS[mutant][0], "case": name, "variant": x["variant"],
                        "row": row, "reference": ref, "observable": x["observable"],
                        "gating": gate.get((x["variant"], row, ref, x["observable"]), False),
                        "margin": x.get("margin"),
                        "effect": e.get("difference"), "effect_ci95": e.get("ci95"), "effect_verdict": e["verdict"],
                        "verdict": x["verdict"], "difference": x.get("difference"), "ci95": x.get("ci95"),
                        "detected": x["verdict"] == "different", "fails_suite": x["verdict"] != "equivalent"})
            for rep in range(false_alarm_repeats):
                g0, g1 = f"{row}@r{rep}.0", f"{row}@r{rep}.1"
                for x in _pair_comparisons(name, c, g0, g1, True, paired=False):
                    false_alarms.append({"case": name, "row": row, "repeat": rep, "variant": x["variant"],
                                         "observable": x["observable"], "verdict": x["verdict"],
                                         "gating": gate.get((x["variant"], row, ref, x["observable"]), False),
                                         "difference": x.get("difference"), "ci95": x.get("ci95")})
        del c["case"]
    main_rows = {k for k in ROWS_OF["drum"]} | {k for k in ROWS_OF["box"]}
    base = [x for x in comparisons if x["a_row"] in main_rows and x["b_row"] in main_rows]
    failures = [f"{x['case']} {x['variant']} {x['a_row']} vs {x['b_row']}: {x['observable']}: {x['verdict']} "
                f"({x.get('reason', '')})" for x in base if x["gating"] and x["verdict"] != "equivalent"]
    failures += [f"{t['case']} {t['row']}: no rise threshold between {t['below']} and {t['above']} ({t['reason']})"
                 for t in thresholds if t["gating"] and not t["present"]]
    report = {"suite": suite, "created": time.strftime("%Y-%m-%d %H:%M:%S"), "rules": "docs/tolerances.md",
              "margins": MARGINS, "power_target": POWER, "cases": cases, "comparisons": base,
              "thresholds": thresholds, "verdict": "pass" if not failures else "fail", "failures": failures}
    if mutants:
        report["mutants"] = mutant_results
        report["detection"] = detection_table(mutant_results)
    if false_alarm_repeats:
        report["false_alarms"] = false_alarm_summary(false_alarms, false_alarm_repeats)
    return report


def detection_table(results):
    """Per mutant: the gating observables whose estimated effect (mutant against
    the unplanted native row, paired by seed) exceeds the margin, and whether
    the suite called the planted row different from the reference engine on
    each. Missed: an effect beyond the margin not called different."""
    def label(r):
        return " ".join(x for x in (r["case"], r["variant"], r.get("row", ""), r["observable"]) if x)

    out = []
    for mutant in dict.fromkeys(r["mutant"] for r in results):
        rs = [r for r in results if r["mutant"] == mutant and r["gating"]]
        beyond = [r for r in rs if r.get("effect") is not None and abs(r["effect"]) > r["margin"]]
        out.append({"mutant": mutant, "description": MUTANTS[mutant][0],
                    "effect_beyond_margin": [label(r) for r in beyond],
                    "detected": [label(r) for r in rs if r["detected"]],
                    "suite_fails": any(r["fails_suite"] for r in rs),
                    "detected_any": any(r["detected"] for r in rs),
                    "missed": [label(r) for r in beyond if not r["detected"]]})
    return out


def false_alarm_summary(results, repeats):
    """Per gating comparison: in how many of the repeats (fresh seeds against
    fresh seeds, same engine) the verdict was different, and inconclusive;
    and the suite-level rate (any gating comparison different in a repeat)."""
    per = {}
    for r in results:
        if not r["gating"]:
            continue
        k = f"{r['case']} {r['variant']} {r['row']} {r['observable']}".replace("  ", " ")
        e = per.setdefault(k, {"repeats": 0, "different": 0, "inconclusive": 0, "equivalent": 0})
        e["repeats"] += 1
        e[r["verdict"]] += 1
    by_repeat = {}
    for r in results:
        if r["gating"]:
            b = by_repeat.setdefault((r["case"], r["row"], r["repeat"]), set())
            b.add(r["verdict"])
    suites = {}
    for (case, row, rep), verdicts in by_repeat.items():
        s = suites.setdefault(f"{case} {row}", {"repeats": 0, "any_different": 0, "all_equivalent": 0})
        s["repeats"] += 1
        s["any_different"] += "different" in verdicts
        s["all_equivalent"] += verdicts == {"equivalent"}
    return {"repeats": repeats, "per_comparison": per, "per_pair": suites}


def box_thresholds(c):
    """Convection onset (and rise threshold) per row over the frequency grid."""
    from .box import onset_threshold
    out = {}
    rows = sorted({r for v in c["variants"].values() for r in v if "+" not in r and "@" not in r})
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


def design_table(suite, cases=None):
    """The power analysis of a suite, before any run: per case, variant,
    observable and same-model pair, the margin, the designed spread, the runs
    POWER requires and the power at the pair's shared seeds (docs/tolerances.md,
    "Sample sizes")."""
    out = []
    for case in [c for c in SUITES[suite] if cases is None or c.name in cases]:
        for variant, observables in case.compared.items():
            for k in observables:
                for a, b in gating_native_rows(case):
                    d = design_of(case, variant, k, case.paired_runs(variant, a, b))
                    out.append({"case": case.name, "variant": variant, "pair": f"{a} vs {b}", "observable": k,
                                "margin": case.margin(k)} | d)
        if case.threshold:  # each row's own rise threshold
            for row in gating_rows_of(case):
                out.append({"case": case.name, "variant": "/".join(case.threshold), "pair": row,
                            "observable": "rise threshold", "margin": None} | threshold_design(case, row))
    return out


def pass_probability(design):
    """The probability that engines that are truly the same pass every gating
    comparison of a design table, at the designed spreads (the comparisons
    taken as independent): how often a correct engine passes the suite."""
    return float(np.prod([d["power"] for d in design if d["gating"]]))


def validate(suite, outdir, lanes=2, rows=None, cases=None, mutants=(), false_alarms=0, log=print,
             device="auto"):
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    unknown = sorted(set(cases or []) - {c.name for c in SUITES[suite]})
    if unknown:
        raise SystemExit(f"validate --cases: no case {', '.join(unknown)} in suite {suite!r} "
                         f"(cases: {', '.join(c.name for c in SUITES[suite])})")
    bad = sorted(set(mutants) - set(MUTANTS))
    if bad:
        raise SystemExit(f"validate --mutants: no mutant {', '.join(bad)} (mutants: {', '.join(MUTANTS)})")
    jobs = jobs_of(suite, outdir, rows, cases)
    if mutants:
        jobs += mutant_jobs(suite, outdir, mutants, cases)
    if false_alarms:
        jobs += false_alarm_jobs(suite, outdir, false_alarms, cases)
    device = native_device(device)
    log(f"validate --suite {suite}: {len(jobs)} runs in {outdir / 'runs'} ({lanes} lanes; "
        f"native drum runs on {device})")
    metas = run_all(jobs, lanes, log, device)
    report = analyse(suite, jobs, metas, mutants, false_alarms)
    report["design"] = design_table(suite, cases)
    report["pass_probability"] = pass_probability(report["design"])
    name = "report" if not (mutants or false_alarms) else "report_" + "_".join(
        (["mutants"] if mutants else []) + ([f"false_alarms{false_alarms}"] if false_alarms else []))
    (outdir / f"{name}.json").write_text(json.dumps(clean_json(report), indent=1))
    from .report_html import write_report
    write_report(report, outdir, name)
    log(f"report: {outdir / (name + '.html')}  verdict: {report['verdict']}")
    for f in report["failures"]:
        log(f"  FAIL {f}")
    for d in report.get("detection", []):
        log(f"  mutant {d['mutant']}: detected {d['detected'] or 'nothing'}; "
            f"effect beyond margin {d['effect_beyond_margin'] or 'nowhere'}; missed {d['missed'] or 'none'}")
    if false_alarms:
        for k, e in report["false_alarms"]["per_comparison"].items():
            log(f"  false alarms {k}: different {e['different']}/{e['repeats']}, inconclusive {e['inconclusive']}")
    return report


# ---------------------------------------------------------------- Markdown for docs/validation.md


def _f(x, digits=3):
    if x is None:
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def _ci(ci):
    return f"[{_f(ci[0])}, {_f(ci[1])}]" if ci else "–"


def _side_md(s):
    if not isinstance(s, dict):
        return "–"
    if "fraction" in s:
        return f"{s['k']}/{s['n']}"
    und = f" ({s['undefined']} undef.)" if s.get("undefined") else ""
    return f"{_f(s['mean'])} ± {_f(s['sd'], 2)}{und}"


def report_markdown(report):
    """The report's comparisons, thresholds, detection table and false alarms
    as Markdown tables (docs/validation.md)."""
    out = [f"Verdict: **{report['verdict']}**" + (f" ({len(report['failures'])} gating checks failed)"
                                                  if report["failures"] else "") + ".", "",
           "| case | variant | A vs B | observable | A | B | B − A [95 %] | margin | MDD | verdict | role |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in report["comparisons"]:
        role = "gating" if c.get("gating") else ("reported: power" if "power" in c.get("why", "") and
                                                  "reported" in c.get("why", "") else "model")
        out.append(f"| {c['case']} | {c['variant'] or '–'} | {c['a_row']} vs {c['b_row']} | {c['observable']} | "
                   f"{_side_md(c.get('a'))} | {_side_md(c.get('b'))} | {_f(c.get('difference'))} {_ci(c.get('ci95'))} | "
                   f"{_f(c.get('margin'))} | {_f(c.get('mdd'))} | {c['verdict']} | {role} |")
    if report.get("thresholds"):
        out += ["", "| case | row | rose at the upper / lower frequency | Fisher p (one-sided) | threshold | "
                    "designed power | role |", "|---|---|---|---|---|---|---|"]
        for t in report["thresholds"]:
            d = t.get("design") or {}
            role = "gating" if t.get("gating") else ("model" if not t.get("same_model_row", True) else "reported: power")
            out.append(f"| {t['case']} | {t['row']} | {_f(t['above_fraction'])} / {_f(t['below_fraction'])} | "
                       f"{_f(t['p'], 2)} | {'shown' if t['present'] else 'NOT shown'} | {_f(d.get('power'), 2)} | "
                       f"{role} |")
    grids = [(name, c) for name, c in report.get("cases", {}).items() if c.get("thresholds")]
    if grids:
        def onset(t):
            if t["threshold"] is not None:
                return f"{t['threshold']:.2f} Hz [{_f(t['lo'])}, {_f(t['hi'])}]"
            return t["threshold_position"].replace("_", " ")
        out += ["", "| case | row | convection onset [95 %] | rise onset [95 %] | risen | risen without convection |",
                "|---|---|---|---|---|---|"]
        for name, c in grids:
            for row, t in c["thresholds"].items():
                rows = [v[row] for v in c["variants"].values() if row in v]
                risen = sum(r["rise"]["k"] for r in rows if r.get("rise"))
                runs = sum(r["rise"]["n"] for r in rows if r.get("rise"))
                alone = sum(r.get("rose_without_convection", 0) for r in rows)
                out.append(f"| {name} | {row} | {onset(t['convection'])} | {onset(t['rise'])} | {risen} of {runs} | "
                           f"{alone} |")
    if report.get("detection"):
        out += ["", "| planted error | gating observables moved beyond the margin | called different | missed | "
                "suite fails |", "|---|---|---|---|---|"]
        for d in report["detection"]:
            out.append(f"| {d['description']} | {', '.join(d['effect_beyond_margin']) or 'none'} | "
                       f"{', '.join(d['detected']) or 'none'} | {', '.join(d['missed']) or 'none'} | "
                       f"{_f(d['suite_fails'])} |")
        out += ["", "| planted error | case | variant | row | observable | effect [95 %] | margin | vs reference |",
                "|---|---|---|---|---|---|---|---|"]
        for m in report["mutants"]:
            if m["gating"]:
                out.append(f"| {m['mutant']} | {m['case']} | {m['variant'] or '–'} | {m['row']} | {m['observable']} | "
                           f"{_f(m['effect'])} {_ci(m['effect_ci95'])} | {_f(m['margin'])} | {m['verdict']} |")
    if report.get("false_alarms"):
        fa = report["false_alarms"]
        out += ["", f"| gating comparison (native against itself, {fa['repeats']} repeats) | different | "
                "inconclusive | equivalent |", "|---|---|---|---|"]
        for k, e in fa["per_comparison"].items():
            out.append(f"| {k} | {e['different']} | {e['inconclusive']} | {e['equivalent']} |")
        for k, e in fa["per_pair"].items():
            out.append(f"| {k}: any gating comparison different / all equivalent | {e['any_different']} | – | "
                       f"{e['all_equivalent']} |")
    return "\n".join(out) + "\n"
