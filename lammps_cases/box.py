"""Poeschel and Herrmann's shaken box in LAMMPS: dimension 2, gran/hooke (the
paper's law with normal-component damping, ENGINES.md), disk inertia
(fix nve/sphere disc), the native engine's wall particles moved with
fix move variable (y_box = A s(t) sin(2 pi f (t - settle)), with the native
start-up envelope s(t), engine/box.cpp) and not integrated, gravity on the
grains, the big disk's trajectory traced as the native engine traces it."""

from __future__ import annotations

import math
import time as wallclock

import numpy as np

from compare.schedule import box_schedule
from compare.schema_writer import SchemaWriter

from .common import check_masses, finish, gather, rank, start
from .scene import SceneRefused, refuse_frozen_rotation

TYPE = {0: 1, 1: 2, 2: 3}  # grain, big disk, wall particle


def refuse_unrepresentable(ini):
    s = ini.scene
    refuse_frozen_rotation(s, "LAMMPS")
    sh, c = s["shaking"], s.get("contact", {})
    if float(sh.get("ramp_time", 0.0)) > 0.0 and float(sh.get("ramp_to", sh["frequency"])) != float(sh["frequency"]):
        raise SceneRefused(f"{sh['ramp_to']} (with shaking.ramp_time): the frequency ramp is not set up in the "
                           "LAMMPS case", key="shaking.ramp_to")
    if c.get("law", "poeschel_herrmann") != "poeschel_herrmann":
        raise SceneRefused(f"\"{c['law']}\": the LAMMPS box runs gran/hooke, Poeschel & Herrmann's law, only",
                           key="contact.law")
    if c.get("damping", "normal") != "normal":
        raise SceneRefused("\"literal\": gran/hooke damps the normal relative velocity only", key="contact.damping")
    if float(s.get("particles", {}).get("inertia_factor", 0.5)) != 0.5:
        raise SceneRefused(f"{s['particles']['inertia_factor']}: fix nve/sphere disc integrates uniform disks, "
                           "I = m R^2 / 2, only", key="particles.inertia_factor")
    if s.get("box", {}).get("walls", "particles") != "particles":
        raise SceneRefused("\"smooth\": smooth walls are not set up in the LAMMPS case, which moves walls of "
                           "particles (fix wall/gran would not give the wall particle's mass in m_eff nor the "
                           "shaker's start-up envelope)", key="box.walls")


def run(ini, out_path, version, nprocs=1, quiet=False, timed_from=None):
    """timed_from: simulated time from which the speed is also timed alone (bench)."""

    refuse_unrepresentable(ini)
    s = ini.scene
    box, sh, c, r = s["box"], s["shaking"], s["contact"], s["run"]
    dt = float(s["integrator"]["dt"])
    settle = float(r["settle"])
    # output steps as engine/box.cpp schedules them (compare/schedule.py)
    total, settle_steps, snaps, traces = box_schedule(s)
    f, amp = float(sh["frequency"]), float(sh["amplitude"])
    startup = float(sh.get("startup_cycles", 2.0))
    g = float(s["gravity"]["g"])
    x = ini.position
    pad = 10.0
    lo = [x[:, 0].min() - pad, x[:, 1].min() - pad, -0.5]
    hi = [x[:, 0].max() + pad, x[:, 1].max() + 100.0, 0.5]

    lmp, data = start(out_path, ini, lo, hi, TYPE)
    P = 2 * math.pi * startup
    w = 2 * math.pi * f
    cmds = [
        "units cgs", "dimension 2", "atom_style sphere", "boundary f f p", "newton off", "comm_modify vel yes",
        f"read_data {data}",
        f"pair_style gran/hooke {float(c['young'])!r} NULL {float(c['gamma_n'])!r} {float(c['gamma_s'])!r} "
        f"{float(c['mu'])!r} 1",
        "pair_coeff * *",
        f"neighbor {float(s['neighbor']['skin'])!r} bin",
        "neigh_modify delay 0 every 1 check yes exclude type 3 3",
        "group grains type 1 2", "group big type 2", "group wall type 3",
        # y_box(t) and its velocity, as ShakerMotion (integrate/motion.hpp) at constant frequency
        f"variable u equal (time>{settle!r})*(time-{settle!r})",
        f"variable ph equal {w!r}*v_u",
        (f"variable env equal (v_ph<{P!r})*v_ph/{P!r}+(v_ph>={P!r})" if startup > 0 else "variable env equal time>" + repr(settle)),
        f"variable dy equal {amp!r}*v_env*sin(v_ph)",
        f"variable vy equal {amp!r}*v_env*cos(v_ph)*{w!r}" +
        (f"+(v_ph<{P!r})*(time>{settle!r})*{amp!r}*sin(v_ph)*{w / P!r}" if startup > 0 else ""),
        # every component prescribed: a NULL component would be integrated from the force
        "variable zero equal 0",
        "fix shake wall move variable v_zero v_dy NULL v_zero v_vy NULL units box",
        f"fix gravity grains gravity {g!r} vector 0 -1 0",
        "fix integrate grains nve/sphere disc",
        "fix plane all enforce2d",
        f"timestep {dt!r}", "thermo 0",
    ]
    if box.get("wall_mass", "particle") == "infinite":
        cmds.insert(cmds.index("fix integrate grains nve/sphere disc"), "fix still wall freeze")
    for cmd in cmds:
        lmp.command(cmd)
    check_masses(lmp, ini)

    n = lmp.get_natoms()
    order = np.argsort(ini.id)
    ids, species, diameter = ini.id[order], ini.species[order].astype(np.int32), ini.diameter[order]
    mass = ini.mass[order]
    grains = species != 2
    big = np.flatnonzero(species == 1)
    mark = int(math.floor(timed_from / dt + 0.5)) if timed_from is not None else None
    stops = sorted(snaps | traces | ({mark} if mark is not None else set()))

    out = None
    if rank() == 0:
        attrs = {"engine": "lammps", "engine_version": version, "scene_kind": "shaken_box", "scene_name": ini.name,
                 "scene_json": ini.attrs["scene_json"], "scene_toml": ini.attrs["scene_toml"],
                 "scene_file": ini.attrs.get("scene_file", ""), "frequency": f, "amplitude": amp, "settle": settle,
                 "box_width": float(box["width"]), "wall_radius": float(box["wall_radius"]),
                 "integrator": "velocity Verlet (fix nve/sphere)", "lammps_processes": nprocs}
        out = SchemaWriter(out_path, 2, n, attrs, ["small", "big", "wall"], with_force=True)
        if len(big):
            out.init_series("trace", {"time": 0, "cycle": 0, "box_y": 0, "big_position": 2, "big_velocity": 2})

    lmp.command("run 0 post no")
    first, done, t0 = True, 0, wallclock.perf_counter()
    clock_mark = None
    for stop in stops:
        if stop > done:
            lmp.command(f"run {stop - done} pre {'yes' if first else 'no'} post no")
            first, done = False, stop
        if done == mark:
            clock_mark = wallclock.perf_counter()
        t = done * dt
        cyc = f * (t - settle)
        xs, vs = gather(lmp, "x", 3), gather(lmp, "v", 3)
        if stop in snaps:
            ws, fs = gather(lmp, "omega", 3), gather(lmp, "f", 3)
            fs[grains, 1] += mass[grains] * g  # contact forces only, as the native engine stores them
        if out is None:
            continue
        if stop in snaps:
            out.frame(t, done, ids, species, diameter, xs, vs, ws, fs)
        if stop in traces and len(big):
            ph = 2 * math.pi * f * max(t - settle, 0.0)
            env = min(1.0, ph / P) if startup > 0 else float(t > settle)
            out.series(time=t, cycle=cyc, box_y=amp * env * math.sin(ph), big_position=xs[big[0], :2],
                       big_velocity=vs[big[0], :2])
        if not quiet:
            el = wallclock.perf_counter() - t0
            print(f"\r  t = {t:.2f} / {total * dt:.2f} s  {done * n / max(el, 1e-9):.3g} atom-steps/s", end="",
                  flush=True)
    return finish(lmp, out, t0, total, n, quiet, (mark, clock_mark))
