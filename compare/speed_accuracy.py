"""Speed against accuracy of the contact laws and integrators
(docs/speed_accuracy.md).

The binary-collision part: ``build/collision_sweep`` measures, per method and
time step (expressed as steps per contact), the restitution and contact-time
errors of a damped collision and the energy error |1 - e^2| of an undamped
one. Here each step size is turned into a cost for the scene the method
serves: CPU seconds per simulated rotation (drum #A) or per simulated second
(the box), from the method's measured particle-steps per second,

    cost = N * (steps per unit time) / rate,   steps per unit time = 1 / dt,

assuming the cost of a particle-step does not depend on dt (it grows slowly
with dt through more frequent neighbour-list builds, so costs at large dt are
slight underestimates). The Pareto front over all methods of a scene, in
(cost, error), is marked.
"""

from __future__ import annotations

import json
import math
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# Particle-steps/s on one thread, `compare bench` of 2026-11-21 (second
# sitting, docs/model_mapping.md): the rates the costs are computed from.
RATES = {
    "drum rapaport leapfrog": 6.07e6,
    "drum linear leapfrog": 6.57e6,
    "drum viscel leapfrog": 6.49e6,
    "box poeschel-herrmann gear5": 1.88e7,
    "box poeschel-herrmann leapfrog": 2.37e7,
}


@dataclass
class SceneCost:
    name: str
    particles: int
    unit: str             # "rotation" or "s"
    unit_time: float      # simulated time of one unit
    default_dt: float


def scene_costs():
    """Drum #A and the 3 Hz box, from `granular info`."""
    def info(scene):
        out = subprocess.run([str(ROOT / "build" / "granular"), "info", str(ROOT / scene), "--json"],
                             capture_output=True, text=True, check=True).stdout
        return json.loads(out)
    a = info("scenes/drum/A.toml")
    b = info("scenes/box/f3.0_big.toml")
    return {
        "drum": SceneCost("drum #A", int(a["derived"]["particles"]), "rotation",
                          float(a["derived"]["rotation_period"]), float(a["integrator"]["dt"])),
        "box": SceneCost("box, 3 Hz", int(b["derived"]["particles"]), "s", 1.0, float(b["integrator"]["dt"])),
    }


def run_sweep(binary=None):
    binary = binary or ROOT / "build" / "collision_sweep"
    out = subprocess.run([str(binary), str(ROOT / "scenes/drum/A.toml"), str(ROOT / "scenes/box/f3.0_big.toml")],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def with_costs(rows, scenes):
    out = []
    for r in rows:
        sc = scenes["drum" if r["method"].startswith("drum") else "box"]
        cost = sc.particles * (sc.unit_time / r["dt"]) / RATES[r["method"]]
        out.append(dict(r, scene=sc.name, cost_s=cost, cost_unit=f"CPU s per simulated {sc.unit}",
                        at_default_dt=bool(r["scene_dt"])))
    return out


def pareto(points):
    """Indices of the (cost, error) points no other point beats in both."""
    idx = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in idx:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def cheapest_within(rows, method, key, tol, damped=True):
    """The largest dt (cheapest) at which `key` stays within tol, and every
    smaller step of the sweep too."""
    rs = sorted((r for r in rows if r["method"] == method and r["damped"] == damped), key=lambda r: r["dt"])
    ok = None
    for r in rs:
        v = r[key]
        if v is None or not (v <= tol):
            break
        ok = r
    return ok


ERRORS = [("restitution_error", True, "restitution error |e - e_ref|"),
          ("contact_time_rel_error", True, "contact-time error |t_c - t_ref| / t_ref"),
          ("energy_error", False, "energy error of an undamped collision |1 - e^2|")]


def plot(rows, out_dir):
    from matplotlib.figure import Figure
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for scene in sorted({r["scene"] for r in rows}):
        fig = Figure(figsize=(13, 4.2), layout="constrained")
        for k, (key, damped, label) in enumerate(ERRORS):
            ax = fig.add_subplot(1, 3, k + 1)
            pts, who = [], []
            for method in sorted({r["method"] for r in rows if r["scene"] == scene}):
                rs = [r for r in rows if r["method"] == method and r["damped"] == damped and r[key] is not None
                      and np.isfinite(r[key]) and r[key] > 0]
                if not rs:
                    continue
                x = [r["cost_s"] for r in rs]
                y = [r[key] for r in rs]
                line, = ax.loglog(x, y, "o-", ms=3, label=method.split(" ", 1)[1])
                for r in rs:
                    if r["at_default_dt"]:
                        ax.loglog([r["cost_s"]], [r[key]], "s", ms=9, mfc="none", color=line.get_color())
                pts += list(zip(x, y))
                who += rs
            if pts:
                f = pareto(pts)
                ax.loglog([pts[i][0] for i in f], [pts[i][1] for i in f], "k--", lw=1, label="Pareto front")
            ax.set_xlabel(f"cost: {who[0]['cost_unit']}" if who else "cost")
            ax.set_ylabel(label)
            ax.grid(True, which="both", alpha=0.3)
            if k == 0:
                ax.legend(fontsize=7)
        fig.suptitle(f"{scene}: binary-collision error against cost (squares: the scene's time step)")
        p = out_dir / f"collision_{scene.split()[0].strip('#,')}.png"
        fig.savefig(p, dpi=120)
        written.append(p)
    return written


def report(out_dir, binary=None):
    scenes = scene_costs()
    rows = with_costs(run_sweep(binary), scenes)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "collision_sweep.json").write_text(json.dumps(rows, indent=1))
    figs = plot(rows, out_dir)
    return rows, figs


def table_markdown(rows, tol_e=1e-3, tol_tc=0.01, tol_energy=1e-3):
    """Per method: error at the scene's step, and the cheapest step keeping
    each error within its tolerance."""
    lines = ["| method | steps per contact at the scene's dt | e error there | t_c error there | "
             f"largest dt with e error ≤ {tol_e:g} | with t_c error ≤ {tol_tc:g} | "
             f"with undamped energy error ≤ {tol_energy:g} |",
             "|---|---|---|---|---|---|---|"]
    for method in RATES:
        rs = [r for r in rows if r["method"] == method and r["damped"]]
        if not rs:
            continue
        sc_dt = None
        for r in rs:
            if r["at_default_dt"]:
                sc_dt = r
        def fmt(r):
            return f"{r['dt']:.3g} ({r['steps_per_contact']:g} steps)" if r else "–"
        lines.append("| {} | {} | {} | {} | {} | {} | {} |".format(
            method,
            f"{sc_dt['steps_per_contact']:g}" if sc_dt else "–",
            f"{sc_dt['restitution_error']:.1e}" if sc_dt else "–",
            f"{sc_dt['contact_time_rel_error']:.1e}" if sc_dt else "–",
            fmt(cheapest_within(rows, method, "restitution_error", tol_e)),
            fmt(cheapest_within(rows, method, "contact_time_rel_error", tol_tc)),
            fmt(cheapest_within(rows, method, "energy_error", tol_energy, damped=False))))
    return "\n".join(lines)
