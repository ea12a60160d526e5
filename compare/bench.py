"""Speed against the peers: the same scenes through the native engine and
LAMMPS (YADE joins when its cases exist), interleaved in one sitting so that
every engine sees the same machine load, with the ratios.

Each case is one command that prints JSON with a particles-steps/s figure:
`granular bench --json` for the native engine, `python3 -m lammps_cases bench
--json` for LAMMPS, `python3 -m yade_cases run --timed-from` for YADE (with --yade). Cases run in rounds (every case once per round, in the
same order), and the median over rounds is reported, with min and max.

The figures are particle-steps per second of wall time: particles counted as
each engine counts them (wall particles of the box included in both), steps
of the scene's own time step. Both engines start from the same initial
state (LAMMPS reads the native engine's `granular init`), settle untimed and
then time the same stretch with output off.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PY = "/usr/bin/python3"


def native_bin() -> Path:
    """The native engine: $GRANULAR_BIN, else the build's."""
    return Path(os.environ.get("GRANULAR_BIN") or ROOT / "build" / "granular")


@dataclass
class Case:
    key: str            # short name in the table
    scene: str          # scenes/... path
    engine: str         # native | lammps
    label: str          # what runs: law, integrator
    workers: int        # threads (native) or MPI ranks (LAMMPS)
    sets: list = field(default_factory=list)
    copies: int = 1     # native: 1-thread runs at once, forked from one state; the rate is their sum (the ceiling)
    repeat: int = 1     # native: runs of the same stretch per round, their median the round's rate
    rates: list = field(default_factory=list)
    builds_per_step: list = field(default_factory=list)  # native: neighbour-list builds per timed step
    particles: int = 0
    rss_per_particle: float = 0.0  # native: peak resident memory / particles
    overlaps: list = field(default_factory=list)  # copies: the share of the shortest run all of them ran, per round
    breakdowns: list = field(default_factory=list)  # native: where the step's time went, per round (breakdown_row)
    scratch: Path = Path("/tmp/compare_bench_yade.h5")  # YADE's output, overwritten each round

    def command(self, timed: float, settle: float) -> list[str]:
        drum = "drum" in self.scene
        sets = sum((["--set", kv] for kv in self.sets), [])
        if self.engine == "yade":
            total = settle + timed
            length = ([f"run.rotations={total!r}", f"run.snapshot_every={2 * total!r}",
                       f"run.profile_every={2 * total!r}"] if drum else
                      [f"run.duration={total!r}", "run.snapshot_every_cycles=1e9", "run.trace_per_cycle=1"])
            return [PY, "-m", "yade_cases", "run", self.scene, "-o", str(self.scratch), "-q", "--force",
                    "--threads", str(self.workers), "--timed-from", repr(settle),
                    *sets, *sum((["--set", kv] for kv in length), [])]
        span = ["--rotations" if drum else "--seconds", repr(timed)]
        return [PY, "-m", "lammps_cases", "bench", self.scene, "--np", str(self.workers), "--settle", repr(settle),
                "--json", *span, *sets]

    def measure(self, timed: float, settle: float) -> float:
        """One run of a peer engine (native cases run in groups: measure_native)."""
        cmd = self.command(timed, settle)
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(f"bench case {self.key} failed ({' '.join(cmd)}):\n{p.stderr.strip()}")
        if self.engine == "yade":
            import h5py
            with h5py.File(self.scratch, "r") as h5:
                rate = float(h5.attrs["timed_atom_steps_per_second"])
                self.particles = int(h5["frames/id"].shape[1])
        else:
            data = json.loads(p.stdout)
            rate, self.particles = float(data["atom_steps_per_second"]), int(data["atoms"])
        self.rates.append(rate)
        return rate

    def summary(self) -> dict:
        return {"key": self.key, "scene": Path(self.scene).stem, "engine": self.engine, "label": self.label,
                "workers": self.workers, "copies": self.copies, "particles": self.particles,
                "rounds": len(self.rates),
                "median": statistics.median(self.rates), "min": min(self.rates), "max": max(self.rates),
                "rates": list(self.rates),
                "peak_rss_bytes": self.rss_per_particle * self.particles if self.rss_per_particle else None,
                "builds_per_step": statistics.median(self.builds_per_step) if self.builds_per_step else None,
                "overlap_min": min(self.overlaps) if self.overlaps else None,
                "breakdown": self.median_breakdown()}

    def median_breakdown(self) -> dict | None:
        """The breakdown of the median round (the lower of the middle two when
        the rounds are even), so that it goes with the rate reported."""
        if not self.breakdowns or len(self.breakdowns) != len(self.rates) or any(b is None for b in self.breakdowns):
            return None
        order = sorted(range(len(self.rates)), key=lambda k: self.rates[k])
        return self.breakdowns[order[(len(order) - 1) // 2]]


def default_cases(threads=(1, 2), lammps_ranks=(1, 2)) -> list[Case]:
    drum, box = "scenes/drum/A.toml", "scenes/box/f3.0_big.toml"
    cases = []
    for t in threads:
        cases.append(Case(f"drum-native-rapaport-{t}t", drum, "native", "Rapaport law, leapfrog", t))
        cases.append(Case(f"drum-native-linear-{t}t", drum, "native", "linear law, leapfrog", t,
                          ["contact.law=linear"]))
    for r in lammps_ranks:
        cases.append(Case(f"drum-lammps-{r}r", drum, "lammps", "linear law, velocity Verlet", r))
    for t in threads:
        cases.append(Case(f"box-native-leapfrog-{t}t", box, "native", "Poeschel-Herrmann law, leapfrog", t,
                          ["integrator.kind=leapfrog"]))
        cases.append(Case(f"box-native-gear-{t}t", box, "native", "Poeschel-Herrmann law, Gear 5th order", t,
                          ["integrator.kind=gear"]))
    cases.append(Case("box-lammps-1r", box, "lammps", "gran/hooke, velocity Verlet", 1))
    if max(threads) > 1:
        # The machine's own ceiling for the thread ratios: as many 1-thread
        # runs at once as the most threads, their rates summed.
        m = max(threads)
        cases.append(Case(f"drum-native-rapaport-{m}x1t", drum, "native",
                          f"Rapaport law, leapfrog: {m} 1-thread runs at once, summed", 1, copies=m))
        cases.append(Case(f"box-native-leapfrog-{m}x1t", box, "native",
                          f"Poeschel-Herrmann law, leapfrog: {m} 1-thread runs at once, summed", 1,
                          ["integrator.kind=leapfrog"], copies=m))
    return cases


def yade_cases(threads=(1, 2)) -> list[Case]:
    """YADE on the same scenes: drum #A under YADE's law mapped from the linear
    law on a facet cylinder, the box under YADE's law with the wall particles
    moved by a Python hook every step (yade_cases/README.md)."""
    drum, box = "scenes/drum/A.toml", "scenes/box/f3.0_big.toml"
    cases = [Case(f"drum-yade-{t}t", drum, "yade", "YADE ViscEl law, leapfrog", t) for t in threads]
    cases += [Case(f"drum-native-viscel-{t}t", drum, "native", "YADE's law (native), leapfrog", t,
                   ["contact.law=viscel"]) for t in threads]
    cases += [Case(f"box-yade-{t}t", box, "yade", "YADE ViscEl law, leapfrog", t) for t in threads]
    return cases


# Drum lengths giving about 1e3, 1e4 and 1e5 particles at drum #A's filling
# (36.4 particles per unit length), each with its runs per round. Every size
# times the same stretch of the flow (the round's rotations after the same
# settling): the drum's contacts and list builds per step change as it runs
# (docs/speed_accuracy.md, "One settled state per round"), so longer stretches
# for the small drums compared their later flow with the large drum's earlier
# one (largest over smallest cost 1.19-1.21 that way, 1.10-1.14 over the same
# stretch). The small drums
# repeat it instead, for at least 10^7 particle-steps (a second) per round.
SCALING_LENGTHS = {28: 10, 280: 2, 2800: 1}


def scaling_cases() -> list[Case]:
    return [Case(f"scale-drum-native-rapaport-L{L}", "scenes/drum/A.toml", "native",
                 f"Rapaport law, leapfrog, drum length {L}, the timed rotations run {k} time{'s' if k > 1 else ''} "
                 f"(the median)", 1,
                 [f"drum.length={L}"], repeat=k) for L, k in SCALING_LENGTHS.items()]


def scaling(rows) -> dict | None:
    """Cost per particle-step over the sizes, its spread, and the marginal memory per particle."""
    sc = sorted([r for r in rows if r["key"].startswith("scale-")], key=lambda r: r["particles"])
    if len(sc) < 2:
        return None
    ns = [1e9 / r["median"] for r in sc]
    out = {"sizes": [{"particles": r["particles"], "ns_per_particle_step": n,
                      "peak_rss_bytes": r["peak_rss_bytes"]} for r, n in zip(sc, ns)],
           "cost_max_over_min": max(ns) / min(ns)}
    # The same within each round (its sizes ran one after another, seconds
    # apart), and the median over the rounds: the steadier figure when the
    # host's speed drifts between rounds.
    if len({len(r["rates"]) for r in sc}) == 1:
        per_round = [max(r["rates"][k] for r in sc) / min(r["rates"][k] for r in sc)
                     for k in range(len(sc[0]["rates"]))]
        out.update(cost_max_over_min_per_round=per_round,
                   cost_max_over_min_per_round_median=statistics.median(per_round))
    a, b = sc[0], sc[-1]
    if a["peak_rss_bytes"] and b["peak_rss_bytes"]:
        out["marginal_bytes_per_particle"] = (b["peak_rss_bytes"] - a["peak_rss_bytes"]) / (b["particles"] - a["particles"])
    return out


# Neighbour-list skins: drum in units of the small diameter (default 0.4),
# box in cm (default 1.0). The skin changes no force (the list holds every
# pair within range + skin and is rebuilt before a pair can close the skin),
# only the cost: fewer builds against more pairs tested per step.
SKINS = {"drum": (0.1, 0.2, 0.4, 0.6, 0.8, 1.2), "box": (0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0)}


def skin_cases() -> list[Case]:
    cases = [Case(f"skin-drum-native-rapaport-{s:g}", "scenes/drum/A.toml", "native",
                  f"Rapaport law, leapfrog, skin {s:g}", 1, [f"neighbor.skin={s!r}"]) for s in SKINS["drum"]]
    cases += [Case(f"skin-box-native-leapfrog-{s:g}", "scenes/box/f3.0_big.toml", "native",
                   f"Poeschel-Herrmann law, leapfrog (the default), skin {s:g} cm", 1,
                   [f"neighbor.skin={s!r}"]) for s in SKINS["box"]]
    return cases


def skin_sweep(rows) -> dict | None:
    """Per scene: skin, particle-steps/s, neighbour-list builds per step."""
    out = {}
    for r in rows:
        if not r["key"].startswith("skin-"):
            continue
        scene = r["key"].split("-")[1]
        out.setdefault(scene, []).append({"skin": float(r["key"].rsplit("-", 1)[1]), "median": r["median"],
                                          "min": r["min"], "max": r["max"],
                                          "builds_per_step": r.get("builds_per_step")})
    for v in out.values():
        v.sort(key=lambda z: z["skin"])
    return out or None


def plot_skin(sweep, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(sweep), figsize=(5 * len(sweep), 3.6), squeeze=False)
    for ax, (scene, pts) in zip(axes[0], sorted(sweep.items())):
        s = [p["skin"] for p in pts]
        ax.errorbar(s, [p["median"] / 1e6 for p in pts],
                    yerr=[[(p["median"] - p["min"]) / 1e6 for p in pts], [(p["max"] - p["median"]) / 1e6 for p in pts]],
                    marker="o", capsize=3, label="particle-steps/s")
        ax.set_xlabel("skin (" + ("small diameters" if scene == "drum" else "cm") + ")")
        ax.set_ylabel("10⁶ particle-steps/s, 1 thread")
        ax.set_title({"drum": "drum #A, Rapaport's law", "box": "box 3 Hz, leapfrog"}.get(scene, scene))
        if all(p["builds_per_step"] is not None for p in pts):
            ax2 = ax.twinx()
            ax2.plot(s, [p["builds_per_step"] for p in pts], "s--", color="tab:red", label="builds per step")
            ax2.set_ylabel("neighbour-list builds per step", color="tab:red")
            ax2.set_yscale("log")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


RATIOS = [  # (numerator, denominator, what it says)
    ("drum-native-linear-1t", "drum-lammps-1r", "drum, same law: native 1 thread / LAMMPS serial"),
    ("drum-native-rapaport-1t", "drum-lammps-1r", "drum: native Rapaport law / LAMMPS linear law, serial"),
    ("drum-native-rapaport-2t", "drum-native-rapaport-1t", "drum: native 2 threads / 1 thread"),
    ("drum-native-linear-2t", "drum-native-linear-1t", "drum, linear law: native 2 threads / 1 thread"),
    ("drum-lammps-2r", "drum-lammps-1r", "drum: LAMMPS 2 ranks / 1 rank"),
    ("drum-native-linear-2t", "drum-lammps-2r", "drum, same law: native 2 threads / LAMMPS 2 ranks"),
    ("box-native-leapfrog-1t", "box-lammps-1r", "box, same law and integrator: native leapfrog / LAMMPS serial"),
    ("box-native-gear-1t", "box-lammps-1r", "box: native Gear / LAMMPS serial"),
    ("box-native-leapfrog-2t", "box-native-leapfrog-1t", "box: native leapfrog 2 threads / 1 thread"),
    ("box-native-gear-2t", "box-native-gear-1t", "box: native Gear 2 threads / 1 thread"),
    ("drum-native-rapaport-2x1t", "drum-native-rapaport-1t",
     "drum: two 1-thread runs at once / one alone (this machine's ceiling for 2 workers)"),
    ("drum-native-rapaport-2t", "drum-native-rapaport-2x1t", "drum: native 2 threads / that ceiling"),
    ("box-native-leapfrog-2x1t", "box-native-leapfrog-1t",
     "box: two 1-thread runs at once / one alone (this machine's ceiling for 2 workers)"),
    ("box-native-leapfrog-2t", "box-native-leapfrog-2x1t", "box: native leapfrog 2 threads / that ceiling"),
    ("drum-native-viscel-1t", "drum-yade-1t", "drum, same law: native 1 thread / YADE 1 thread"),
    ("drum-native-viscel-2t", "drum-yade-2t", "drum, same law: native 2 threads / YADE 2 threads"),
    ("drum-yade-2t", "drum-yade-1t", "drum: YADE 2 threads / 1 thread"),
    ("box-native-leapfrog-1t", "box-yade-1t", "box: native leapfrog / YADE, 1 thread"),
    ("box-native-leapfrog-2t", "box-yade-2t", "box: native leapfrog / YADE, 2 threads"),
    ("box-yade-2t", "box-yade-1t", "box: YADE 2 threads / 1 thread"),
]


def ratio(num: dict, den: dict, what: str) -> dict:
    """num's median rate over den's, and the same ratio round by round: two
    cases of one round ran seconds apart, two rounds minutes apart, so when the
    machine's speed drifts during a launch (another tenant of the host, the
    host moving the two cores apart) the per-round ratios compare runs that
    saw the same machine, and their median is the steadier figure."""
    out = {"numerator": num["key"], "denominator": den["key"], "what": what,
           "ratio": num["median"] / den["median"]}
    if len(num["rates"]) == len(den["rates"]):
        per_round = [a / b for a, b in zip(num["rates"], den["rates"])]
        out.update(per_round=per_round, per_round_median=statistics.median(per_round))
    return out


def groups(cases) -> list[list[Case]]:
    """The cases in the order given, the native ones of one scene, settings and
    repeat count gathered into one group (at the place of its first case): a
    group is one `granular bench` per round, which settles once and times every
    thread count and the ceiling from that state, each in a process forked from
    it, one after another. The ratios between them then compare the same
    stretch of flow run seconds apart, not minutes."""
    out, native = [], {}
    for c in cases:
        if c.engine != "native":
            out.append([c])
            continue
        k = (c.scene, tuple(c.sets), c.repeat)
        if k not in native:
            native[k] = []
            out.append(native[k])
        native[k].append(c)
    return out


def native_command(group: list[Case], timed: float, settle: float) -> list[str]:
    """`granular bench` for a group of native cases (groups): every thread
    count of the group, and the ceiling's copies if it has that case."""
    c0 = group[0]
    threads = sorted({c.workers for c in group if c.copies == 1}) or [1]
    ceiling = max((c.copies for c in group if c.copies > 1), default=0)
    drum = "drum" in c0.scene
    return [str(native_bin()), "bench", c0.scene, "--threads", *map(str, threads), "--repeat", str(c0.repeat),
            "--settle", repr(settle), "--json", "--rotations" if drum else "--seconds", repr(timed),
            *(["--ceiling", str(ceiling)] if ceiling else []), *sum((["--set", kv] for kv in c0.sets), [])]


def measure_native(group: list[Case], timed: float, settle: float) -> list[float]:
    """One `granular bench` for a group of native cases; appends each case's rate."""
    cmd = native_command(group, timed, settle)
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    keys = ", ".join(c.key for c in group)
    if p.returncode != 0:
        raise RuntimeError(f"bench cases {keys} failed ({' '.join(cmd)}):\n{p.stderr.strip()}")
    rows = {(int(r["threads"]), int(r.get("copies", 1))): r for r in json.loads(p.stdout)}
    rates = []
    for c in group:
        row = rows.get((c.workers, c.copies))
        if row is None:
            raise RuntimeError(f"bench case {c.key}: `granular bench` gave no row for {c.workers} thread(s) x "
                               f"{c.copies} ({' '.join(cmd)})")
        rate = float(row["particle_steps_per_second"])
        if c.copies > 1:
            c.overlaps.append(float(row["overlap"]))
        c.particles = int(row["particles"])
        c.rss_per_particle = float(row.get("peak_rss_bytes_per_particle", 0.0))
        if row.get("steps"):
            c.builds_per_step.append(float(row.get("neighbor_builds", 0)) / float(row["steps"]))
        c.breakdowns.append(breakdown_row(row) if c.copies == 1 else None)
        c.rates.append(rate)
        rates.append(rate)
    return rates


PHASES = ("integrate", "neighbor", "pairs", "walls", "observe")


def breakdown_row(row: dict) -> dict | None:
    """Where a native run's step spent its time, from `granular bench --json`'s
    row (its median round): each phase in ns per particle-step and as a share
    of the timed stretch, the neighbour-list builds per step, and the pair loop
    per contact beside a bare kernel over a fixed contact list (the law's
    pair_force over the run's final contacts, one thread; engine/timers.hpp).
    None for an engine build that does not report it."""
    b = row.get("breakdown")
    if not b or not b.get("steps") or not b.get("seconds"):
        return None
    work = float(b["steps"]) * float(row["particles"])
    out = {"phase_ns_per_particle_step": {k: 1e9 * float(b["phase_seconds"].get(k, 0.0)) / work for k in PHASES},
           "phase_share": {k: float(b["phase_seconds"].get(k, 0.0)) / float(b["seconds"]) for k in PHASES},
           "ns_per_particle_step": 1e9 * float(b["seconds"]) / work,
           "builds_per_step": float(row.get("neighbor_builds", 0)) / float(b["steps"]),
           "threads": int(b.get("threads", 1))}
    if b.get("contacts"):
        loop, bare = float(b["pair_loop_ns_per_contact"]), float(b["bare_kernel_ns_per_contact"])
        out.update(contacts=int(b["contacts"]), pair_loop_ns_per_contact=loop, bare_kernel_ns_per_contact=bare,
                   pair_loop_over_bare=loop / bare)
    return out


def breakdown_table(cases: list[dict]) -> list[str]:
    """Markdown: each native case's breakdown (its median round)."""
    rows = [r for r in cases if r.get("breakdown")]
    if not rows:
        return []
    lines = ["", "Where the native step spends its time (each case's median round; ns per particle-step, the "
             "share of the timed stretch in brackets). The pair loop per contact is set beside a bare kernel: the "
             "law's pair force over the run's final contacts as a fixed list, one thread, no neighbour list.", "",
             "| case | step | " + " | ".join(PHASES) + " | builds per step | pair loop (ns per contact) | "
             "bare kernel | loop / bare |",
             "|---|---|" + "---|" * len(PHASES) + "---|---|---|---|"]
    for r in rows:
        b = r["breakdown"]
        cells = [f"{b['phase_ns_per_particle_step'][k]:.1f} ({100 * b['phase_share'][k]:.0f} %)" for k in PHASES]
        tail = (f"{b['pair_loop_ns_per_contact']:.1f} | {b['bare_kernel_ns_per_contact']:.1f} | "
                f"{b['pair_loop_over_bare']:.2f}" if "pair_loop_ns_per_contact" in b else " | | ")
        lines.append(f"| {r['key']} | {b['ns_per_particle_step']:.1f} | " + " | ".join(cells) +
                     f" | {b['builds_per_step']:.3f} | {tail} |")
    return lines


def run_bench(cases, rounds=3, drum_rotations=1.0, drum_settle=0.5, box_seconds=1.0, box_settle=1.0,
              progress=sys.stderr) -> dict:
    t_start = time.time()
    for r in range(rounds):
        for g in groups(cases):
            drum = "drum" in g[0].scene
            timed, settle = (drum_rotations, drum_settle) if drum else (box_seconds, box_settle)
            rates = measure_native(g, timed, settle) if g[0].engine == "native" else [g[0].measure(timed, settle)]
            if progress:
                for c, rate in zip(g, rates):
                    print(f"round {r + 1}/{rounds}  {c.key:28s} {rate:10.3g} particle-steps/s", file=progress,
                          flush=True)
    rows = [c.summary() for c in cases]
    by = {row["key"]: row for row in rows}
    ratios = [ratio(by[a], by[b], w) for a, b, w in RATIOS if a in by and b in by]
    return {"machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                        "load_before": os.getloadavg()[0]},
            "settings": {"rounds": rounds, "drum_rotations": drum_rotations, "drum_settle_rotations": drum_settle,
                         "box_seconds": box_seconds, "box_settle_seconds": box_settle},
            "wall_seconds": time.time() - t_start, "cases": rows, "ratios": ratios, "scaling": scaling(rows),
            "skin": skin_sweep(rows)}


def markdown(result) -> str:
    lines = ["| case | engine | what runs | workers | particles | particle-steps/s (median) | min – max |",
             "|---|---|---|---|---|---|---|"]
    for r in result["cases"]:
        label = r["label"] + (f" (all ran together for at least {100 * r['overlap_min']:.0f} % of the shortest)"
                              if r.get("overlap_min") is not None else "")
        lines.append(f"| {r['key']} | {r['engine']} | {label} | {r['workers']} | {r['particles']} | "
                     f"{r['median']:.3g} | {r['min']:.3g} – {r['max']:.3g} |")
    lines += ["", "| ratio | of the medians | round by round: median (min – max) |", "|---|---|---|"]
    lines += [f"| {q['what']} | {q['ratio']:.2f} | " + (
        f"{q['per_round_median']:.2f} ({min(q['per_round']):.2f} – {max(q['per_round']):.2f})"
        if "per_round" in q else "") + " |" for q in result["ratios"]]
    lines += breakdown_table(result["cases"])
    sc = result.get("scaling")
    if sc:
        lines += ["", "| particles | ns per particle-step | peak memory (MB) |", "|---|---|---|"]
        lines += [f"| {z['particles']} | {z['ns_per_particle_step']:.1f} | "
                  f"{z['peak_rss_bytes'] / 1e6:.1f} |" for z in sc["sizes"]]
        pr = sc.get("cost_max_over_min_per_round")
        lines += ["", f"Cost per particle-step, largest over smallest: {sc['cost_max_over_min']:.2f} (of the medians)"
                  + (f", {sc['cost_max_over_min_per_round_median']:.2f} round by round ({min(pr):.2f} – {max(pr):.2f})"
                     if pr else "") + "; "
                  f"marginal memory {sc.get('marginal_bytes_per_particle', float('nan')):.0f} bytes per particle."]
    sk = result.get("skin")
    if sk:
        lines += ["", "| scene | skin | particle-steps/s (median) | min – max | builds per step |", "|---|---|---|---|---|"]
        for scene, pts in sorted(sk.items()):
            lines += [f"| {scene} | {p['skin']:g} | {p['median']:.3g} | {p['min']:.3g} – {p['max']:.3g} | "
                      f"{p['builds_per_step']:.3f} |" if p["builds_per_step"] is not None else
                      f"| {scene} | {p['skin']:g} | {p['median']:.3g} | {p['min']:.3g} – {p['max']:.3g} | |"
                      for p in pts]
    s = result["settings"]
    lines += ["", f"{s['rounds']} interleaved rounds; drum: {s['drum_settle_rotations']} rotations settled, "
              f"{s['drum_rotations']} timed; box: {s['box_settle_seconds']} s of shaking settled, "
              f"{s['box_seconds']} s timed; {result['wall_seconds']:.0f} s in all."]
    return "\n".join(lines) + "\n"


def main(args) -> int:
    cases = (default_cases() + (yade_cases() if args.yade else []) + (scaling_cases() if args.scaling else [])
             + (skin_cases() if getattr(args, "skin", False) else []))
    if args.only:
        cases = [c for c in cases if any(k in c.key for k in args.only)]
        if not cases:
            print(f"bench: error: no case matches {args.only}", file=sys.stderr)
            return 2
    try:
        result = run_bench(cases, rounds=args.rounds, drum_rotations=args.rotations, box_seconds=args.seconds)
    except RuntimeError as exc:
        print(f"bench: error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench.json").write_text(json.dumps(result, indent=2) + "\n")
    if result.get("skin"):
        plot_skin(result["skin"], out / "skin.png")
    md = markdown(result)
    (out / "bench.md").write_text(md)
    print(md)
    return 0
