"""A particles scene (kind = "particles", docs/particles_scene.md) in LAMMPS:
explicit spheres and plane walls under the linear law mapped from Rapaport's
(derived["linear_law"] of `granular init`, the coefficients the native
engine's contact.law = "linear" runs): pair_style granular per type pair
(hooke, linear_nohistory, damping mass_velocity), each wall a plane region
moved in by the mapped inset (wall_inset = 2^(1/6) d_w / 2, zero thickness)
with one fix wall/gran/region per species, gravity along -z, fix nve/sphere
(velocity Verlet: the native leapfrog's two stages, integrate/leapfrog.hpp).
Frames at the native engine's steps (compare.schedule.particles_schedule)."""

from __future__ import annotations

import time as wallclock

import numpy as np

from compare.schedule import particles_schedule
from compare.schema_writer import SchemaWriter

from .common import check_masses, finish, gather, pair_coeff, rank, start
from .scene import SceneRefused, refuse_frozen_rotation

TYPE = {0: 1, 1: 2}  # species small, big -> LAMMPS types
SPECIES = ("small", "big")


def refuse_unrepresentable(ini):
    s = ini.scene
    refuse_frozen_rotation(s, "LAMMPS")
    c = s.get("contact", {})
    if abs(float(c.get("kappa", 0.2)) - 0.2) > 1e-12:
        raise SceneRefused(f"{c['kappa']}: LAMMPS's spheres have I = 2/5 m r^2 (kappa = 0.2)", key="contact.kappa")
    if s.get("integrator", {}).get("kind", "leapfrog") != "leapfrog":
        raise SceneRefused("LAMMPS runs velocity Verlet (fix nve/sphere) only", key="integrator.kind")
    if "pair" not in ini.derived.get("linear_law", {}):
        raise SceneRefused(f"the linear law cannot be mapped here: {ini.derived.get('linear_law')}",
                           key="contact.law")


def run(ini, out_path, version, nprocs=1, quiet=False, timed_from=None):
    refuse_unrepresentable(ini)
    s, lin = ini.scene, ini.derived["linear_law"]
    dt = float(s["integrator"]["dt"])
    total, snaps = particles_schedule(s)
    inset = float(lin["wall_inset"])
    x0, d_max = ini.position, float(ini.diameter.max())
    margin = 2.0 * d_max + float(s["neighbor"]["skin"])
    lo, hi = list(x0.min(axis=0) - margin), list(x0.max(axis=0) + margin)

    lmp, data = start(out_path, ini, lo, hi, TYPE)
    pc, wc = lin["pair"], lin["wall"]
    cmds = [
        "units lj", "atom_style sphere", "dimension 3",
        "boundary m m m",  # open: the box follows the particles
        "newton off", "comm_modify vel yes",
        f"read_data {data}",
        "pair_style granular",
        f"pair_coeff 1 1 {pair_coeff(pc['small_small'])}",
        f"pair_coeff 1 2 {pair_coeff(pc['small_big'])}",
        f"pair_coeff 2 2 {pair_coeff(pc['big_big'])}",
        f"neighbor {float(s['neighbor']['skin'])!r} bin",
        "neigh_modify delay 0 every 1 check yes",
        "group small type 1", "group big type 2",
    ]
    for k, w in enumerate(s.get("wall", [])):
        nrm = np.asarray(w["normal"], dtype=float)
        nrm /= np.linalg.norm(nrm)
        p = np.asarray(w["point"], dtype=float) + inset * nrm  # the mapped laws' wall surface
        cmds.append(f"region wall{k} plane {p[0]!r} {p[1]!r} {p[2]!r} {nrm[0]!r} {nrm[1]!r} {nrm[2]!r} "
                    "side in units box")
        for sp in (0, 1):
            if np.any(ini.species == sp):  # one fix per species: the wall coefficients are per species
                cmds.append(f"fix wall{k}_{SPECIES[sp]} {SPECIES[sp]} wall/gran/region granular "
                            f"{pair_coeff(wc[SPECIES[sp]])} region wall{k}")
    g = float(s.get("gravity", {}).get("g", 0.0))
    if g > 0.0:
        cmds.append(f"fix gravity all gravity {g!r} vector 0 0 -1")
    cmds += ["fix integrate all nve/sphere", f"timestep {dt!r}", "thermo 0"]
    for c in cmds:
        lmp.command(c)
    check_masses(lmp, ini)

    n = lmp.get_natoms()
    order = np.argsort(ini.id)
    ids, species, diameter = ini.id[order], ini.species[order].astype(np.int32), ini.diameter[order]
    out = None
    if rank() == 0:
        attrs = {"engine": "lammps", "engine_version": version, "scene_kind": "particles", "scene_name": ini.name,
                 "scene_json": ini.attrs["scene_json"], "scene_toml": ini.attrs["scene_toml"],
                 "scene_file": ini.attrs.get("scene_file", ""), "lammps_processes": nprocs,
                 "integrator": "velocity Verlet (fix nve/sphere)",
                 "contact_law": "linear (mapped from Rapaport, docs/model_mapping.md)"}
        out = SchemaWriter(out_path, 3, n, attrs, ["small", "big"])

    lmp.command("run 0 post no")
    first, done, t0 = True, 0, wallclock.perf_counter()
    for stop in sorted(snaps):
        if stop > done:
            lmp.command(f"run {stop - done} pre {'yes' if first else 'no'} post no")
            first, done = False, stop
        x, v, w = gather(lmp, "x", 3), gather(lmp, "v", 3), gather(lmp, "omega", 3)
        if out is not None:
            out.frame(done * dt, done, ids, species, diameter, x, v, w)
    return finish(lmp, out, t0, total, n, quiet)
