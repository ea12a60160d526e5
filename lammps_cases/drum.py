"""Rapaport's drum in LAMMPS: the linear law mapped from Rapaport's
(docs/model_mapping.md) through pair_style granular per type pair, the
rotating curved wall as a rotating cylinder region with one
fix wall/gran/region per species (species-dependent wall friction), rotating
plane regions for capped ends, gravity along -z, fix nve/sphere."""

from __future__ import annotations

import math
import time as wallclock

import numpy as np

from compare.schedule import drum_schedule, lround
from compare.schema_writer import SchemaWriter, axial_small_fraction

from .common import check_masses, finish, gather, pair_coeff, rank, start
from .scene import SceneRefused, refuse_frozen_rotation

TYPE = {0: 1, 1: 2}  # species small, big -> LAMMPS types


def refuse_unrepresentable(ini):
    s = ini.scene
    refuse_frozen_rotation(s, "LAMMPS")
    c = s.get("contact", {})
    if abs(float(c.get("kappa", 0.2)) - 0.2) > 1e-12:
        raise SceneRefused(f"{c['kappa']}: LAMMPS's spheres have I = 2/5 m r^2 (kappa = 0.2)", key="contact.kappa")
    if s.get("integrator", {}).get("kind", "leapfrog") != "leapfrog":
        raise SceneRefused("LAMMPS runs velocity Verlet (fix nve/sphere) only", key="integrator.kind")


def run(ini, out_path, version, nprocs=1, quiet=False, timed_from=None):
    """timed_from: simulated time from which the speed is also timed alone (bench)."""

    refuse_unrepresentable(ini)
    s, d = ini.scene, ini.derived
    lin = d["linear_law"]
    drum = s["drum"]
    omega, dt = float(drum["omega"]), float(s["integrator"]["dt"])
    length, capped = float(drum["length"]), drum["ends"] == "capped"
    period = 2 * math.pi / omega
    # output steps as engine/drum.cpp schedules them (compare/schedule.py)
    total, snap_steps, prof_steps, edges = drum_schedule(s)
    rc = 0.5 * float(lin["contact_diameter"])
    lc = float(lin["contact_length"])
    margin = 2.0
    half_d = 0.5 * float(drum["diameter"])
    lo = [-half_d - margin, -0.5 * length - (margin if capped else 0.0), -half_d - margin]
    hi = [half_d + margin, 0.5 * length + (margin if capped else 0.0), half_d + margin]

    lmp, data = start(out_path, ini, lo, hi, TYPE)
    if nprocs > 1:
        lmp.command("processors 1 * 1")  # split along the axis (ENGINES.md)
    pc = lin["pair"]
    cmds = [
        "units lj", "atom_style sphere", "dimension 3",
        f"boundary f {'f' if capped else 'p'} f",
        "newton off", "comm_modify vel yes",
        f"read_data {data}",
        "pair_style granular",
        f"pair_coeff 1 1 {pair_coeff(pc['small_small'])}",
        f"pair_coeff 1 2 {pair_coeff(pc['small_big'])}",
        f"pair_coeff 2 2 {pair_coeff(pc['big_big'])}",
        f"neighbor {float(s['neighbor']['skin'])!r} bin",
        "neigh_modify delay 0 every 1 check yes",
        "group small type 1", "group big type 2",
        # the drum turns with angular velocity omega about -y (boundary/cylinder_wall.hpp: wall velocity
        # Omega (D/2) r^ x y^); theta is the region's rotation angle about (0, -1, 0)
        f"variable theta equal {omega!r}*time",
        f"region drum cylinder y 0 0 {rc!r} INF INF side in rotate v_theta 0 0 0 0 -1 0 units box",
    ]
    region = "drum"
    if capped:
        cmds += [
            f"region capneg plane 0 {-0.5 * lc!r} 0 0 1 0 side in rotate v_theta 0 0 0 0 -1 0 units box",
            f"region cappos plane 0 {0.5 * lc!r} 0 0 -1 0 side in rotate v_theta 0 0 0 0 -1 0 units box",
            "region walls intersect 3 drum capneg cappos",
        ]
        region = "walls"
    wc = lin["wall"]
    cmds += [
        f"fix wall_small small wall/gran/region granular {pair_coeff(wc['small'])} region {region}",
        f"fix wall_big big wall/gran/region granular {pair_coeff(wc['big'])} region {region}",
        f"fix gravity all gravity {float(s['gravity']['g'])!r} vector 0 0 -1",
        "fix integrate all nve/sphere",
        f"timestep {dt!r}",
        "thermo 0",
    ]
    for c in cmds:
        lmp.command(c)
    check_masses(lmp, ini)

    n = lmp.get_natoms()
    ids = np.arange(n, dtype=np.int64)  # LAMMPS id k+1 = native id k
    order = np.argsort(ini.id)
    species = ini.species[order].astype(np.int32)
    diameter = ini.diameter[order]
    mark = lround(timed_from / dt) if timed_from is not None else None
    stops = sorted(snap_steps | prof_steps | ({mark} if mark is not None else set()))

    out = None
    if rank() == 0:
        attrs = {"engine": "lammps", "engine_version": version, "scene_kind": "drum", "scene_name": ini.name,
                 "scene_json": ini.attrs["scene_json"], "scene_toml": ini.attrs["scene_toml"],
                 "scene_file": ini.attrs.get("scene_file", ""), "omega": omega, "rotation_period": period,
                 "lammps_processes": nprocs, "contact_law": "linear (mapped from Rapaport, docs/model_mapping.md)"}
        out = SchemaWriter(out_path, 3, n, attrs, ["small", "big"])
        out.init_profile(edges)

    lmp.command("run 0 post no")  # set-up: forces at t = 0
    first = True
    done, t0 = 0, wallclock.perf_counter()
    clock_mark = None
    for stop in stops:
        if stop > done:
            # continuing runs skip the set-up, so the region's motion is continuous
            lmp.command(f"run {stop - done} pre {'yes' if first else 'no'} post no")
            first = False
            done = stop
        if done == mark:
            clock_mark = wallclock.perf_counter()
        x = gather(lmp, "x", 3)
        if not capped:
            x[:, 1] = (x[:, 1] + 0.5 * length) % length - 0.5 * length
        if stop in snap_steps:  # gathering is collective: every rank takes part
            v, w = gather(lmp, "v", 3), gather(lmp, "omega", 3)
        if out is not None:
            t = done * dt
            if stop in prof_steps:
                out.profile(t, axial_small_fraction(x[:, 1], diameter, species, edges))
            if stop in snap_steps:
                out.frame(t, done, ids, species, diameter, x, v, w)
        if not quiet and rank() == 0:
            el = wallclock.perf_counter() - t0
            print(f"\r  rotation {done * dt / period:.2f} / {total * dt / period:.2f}  "
                  f"{done * n / max(el, 1e-9):.3g} atom-steps/s", end="", flush=True)
    return finish(lmp, out, t0, total, n, quiet, (mark, clock_mark))
