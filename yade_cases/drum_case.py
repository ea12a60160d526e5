"""Rapaport's drum in YADE 2023.02a, run by the launcher (python3 -m yade_cases):
    yade -n -x [-jN] yade_cases/drum_case.py WORKDIR OUT.h5
WORKDIR holds initial.npz and case.json (yade_cases/common.py).

The native linear law (contact/linear.hpp) as ViscElMat materials, one per
particle (yade_cases/mapping.py); the rotating curved wall as two identical
facet cylinders (one per species, with its own wall material; mask bits keep
each species on its own cylinder), turned by a RotationEngine about -y with
angular velocity Omega; periodic along y (a periodic cell, wide in x and z) or
capped by facet discs that turn with the drum; gravity along -z;
NewtonIntegrator(damping=0); masses and moments of inertia from the native
initial state. The tangential force is YADE's: viscous, never capped by
Coulomb (frictionAngle = 0, ks = 0)."""

import json
import math
import sys
from pathlib import Path

ROOT = Path(sys.argv[0]).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from yade import O, geom, utils  # noqa: E402
from yade.wrapper import (ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, Bo1_Facet_Aabb,  # noqa: E402
                          InteractionLoop, Ig2_Sphere_Sphere_ScGeom, Ig2_Facet_Sphere_ScGeom,
                          Ip2_ViscElMat_ViscElMat_ViscElPhys, Law2_ScGeom_ViscElPhys_Basic, NewtonIntegrator,
                          RotationEngine, ViscElMat)
from yade.minieigenHP import Quaternion, Vector3  # noqa: E402

from compare.schema_writer import SchemaWriter, axial_small_fraction  # noqa: E402
from compare.schedule import drum_schedule  # noqa: E402
from yade_cases.common import read_workdir  # noqa: E402
from yade_cases.mapping import (SPECIES, check_viscel_law, mismatch, pair_values, particle_material,  # noqa: E402
                                polygon_radius_error, viscel_from_linear, wall_spread)
from yade_cases.yade_side import Progress, run_steps, states, version, script_main  # noqa: E402

# Mask bits (ENGINES.md): small spheres 9, big 12; small-species wall 3, big 20;
# the collider's avoidSelfInteractionMask 18 keeps the facets of one cylinder
# (same mask) from pairing with each other. 9 & 20 = 0, 12 & 3 = 0, 3 & 20 = 0.
SPHERE_MASK = {0: 9, 1: 12}
WALL_MASK = {0: 3, 1: 20}
AVOID_SELF = 18


def segments_for(radius: float, tolerance: float) -> int:
    """Smallest multiple of 8 whose polygon (vertices on the circle) lies within
    tolerance of the circle: R (1 - cos(pi/N)) <= tolerance."""
    n = 8
    while polygon_radius_error(radius, n) > tolerance:
        n += 8
    return n


def build(case, ini):
    s, d = case["scene"], case["derived"]
    opts = case["options"]
    lin = d["linear_law"]
    drum = s["drum"]
    omega, dt, g = float(drum["omega"]), float(s["integrator"]["dt"]), float(s["gravity"]["g"])
    length, capped = float(drum["length"]), drum["ends"] == "capped"
    rc = 0.5 * float(lin["contact_diameter"])
    lc = float(lin["contact_length"])
    species, mass = ini["species"].astype(int), ini["mass"]
    if "viscel_law" in d:
        law = d["viscel_law"]
        check_viscel_law(law)
        law_source = "derived[\"viscel_law\"] (granular init)"
    else:  # the same rule, with the linear law's wall m_eff (the nominal species masses) as reference
        law = viscel_from_linear(lin, {sp: float(lin["wall"][sp]["m_eff"]) for sp in SPECIES})
        law_source = "yade_cases.mapping.viscel_from_linear(derived[\"linear_law\"])"

    if not capped:
        O.periodic = True
        side = 2.0 * float(drum["diameter"]) + 8.0  # no images across x or z
        O.cell.setBox(side, length, side)

    # particles: body id k = native id k (the arrays are sorted by id)
    n = len(ini["id"])
    assert np.array_equal(ini["id"], np.arange(n)), "native ids are not 0..n-1"
    for i in range(n):
        k = int(species[i])
        m = particle_material(law, SPECIES[k], float(mass[i]))
        di = float(ini["diameter"][i])
        rho = float(mass[i]) / (math.pi / 6.0 * di ** 3)
        mat = O.materials.append(ViscElMat(kn=m["kn"], cn=m["cn"], ks=0.0, cs=m["cs"], frictionAngle=0.0, density=rho))
        b = utils.sphere(tuple(ini["position"][i]), 0.5 * di, material=mat, mask=SPHERE_MASK[k])
        b.state.mass = float(mass[i])
        b.state.inertia = Vector3(*([float(ini["inertia"][i])] * 3))
        b.state.vel = Vector3(*ini["velocity"][i])
        b.state.angVel = Vector3(*ini["angular_velocity"][i])
        O.bodies.append(b)

    # the wall: two identical facet cylinders (axis y), one per species
    segments = int(opts.get("segments") or segments_for(rc, float(opts.get("radius_tolerance", 1e-2))))
    if capped:
        rings = 1
    else:
        # a facet strictly shorter than half the period (ENGINES.md: YADE refuses a body spanning
        # half the periodic cell or more), so at least three rings
        rings = max(3, int(math.ceil(length / 32.0)))
    ring_len = (lc if capped else length) / rings
    to_y = Quaternion(Vector3(1, 0, 0), -math.pi / 2)  # facetCylinder's axis is z: turn it to y
    facet_ids = []
    for k, sp in enumerate(SPECIES):
        w = law["wall_materials"][sp]
        wmat = O.materials.append(ViscElMat(kn=w["kn"], cn=w["cn"], ks=0.0, cs=w["cs"], frictionAngle=0.0,
                                            density=1.0))
        for r in range(rings):
            yc = -0.5 * (lc if capped else length) + (r + 0.5) * ring_len
            fs = geom.facetCylinder((0, yc, 0), rc, ring_len, orientation=to_y, segmentsNumber=segments,
                                    wallMask=7 if capped else 4, material=wmat, mask=WALL_MASK[k])
            facet_ids += O.bodies.append(fs)
    # the facets move with the drum from the first step on (the engine sets them from step 0's end)
    axis = Vector3(0, -omega, 0)
    for i in facet_ids:
        st = O.bodies[i].state
        st.angVel = axis
        st.vel = axis.cross(st.pos)

    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], avoidSelfInteractionMask=AVOID_SELF),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                        [Ip2_ViscElMat_ViscElMat_ViscElPhys()], [Law2_ScGeom_ViscElPhys_Basic()]),
        RotationEngine(ids=facet_ids, rotationAxis=(0, -1, 0), angularVelocity=omega, rotateAroundZero=True,
                       zeroPoint=(0, 0, 0)),
        NewtonIntegrator(damping=0.0, gravity=(0, 0, -g)),
    ]
    O.dt = dt
    info = {"law": law, "law_source": law_source, "segments": segments, "rings": rings, "facets": len(facet_ids),
            "radius": rc, "radius_error": polygon_radius_error(rc, segments),
            "pairs": pair_values(law, lin), "wall_spread": wall_spread(law, lin, species, mass),
            "mismatch": mismatch(law, lin)}
    return info


def main(work, out_path):
    case, ini = read_workdir(work)
    s = case["scene"]
    opts = case["options"]
    quiet = bool(opts.get("quiet"))
    info = build(case, ini)
    drum, dt = s["drum"], float(s["integrator"]["dt"])
    omega, length, capped = float(drum["omega"]), float(drum["length"]), drum["ends"] == "capped"
    period = 2 * math.pi / omega
    total, snap_steps, prof_steps, edges = drum_schedule(s)
    stops = sorted(snap_steps | prof_steps)
    mark = opts.get("timed_from_step")
    if mark is not None:
        stops = sorted(set(stops) | {int(mark)})

    n = len(ini["id"])
    ids = np.arange(n, dtype=np.int64)
    species, diameter = ini["species"].astype(np.int32), ini["diameter"]
    law = info["law"]
    attrs = {"engine": "yade", "engine_version": version(), "scene_kind": "drum", "scene_name": case["name"],
             "scene_json": case["attrs"]["scene_json"], "scene_toml": case["attrs"]["scene_toml"],
             "scene_file": case["attrs"].get("scene_file", ""), "omega": omega, "rotation_period": period,
             "contact_law": "YADE ViscElMat (Law2_ScGeom_ViscElPhys_Basic): the linear law mapped from Rapaport's "
                            "(docs/model_mapping.md) with harmonic mixing and an uncapped viscous tangential force",
             "integrator": "leapfrog (YADE NewtonIntegrator, damping 0)",
             "yade_threads": int(opts.get("threads", 1)),
             "yade_viscel_law": json.dumps(law), "yade_viscel_law_source": info["law_source"],
             "yade_mixing_mismatch": json.dumps(info["mismatch"]),
             "yade_pair_values": json.dumps(info["pairs"]), "yade_wall_mass_spread": json.dumps(info["wall_spread"]),
             "yade_wall": (f"2 facet cylinders x {info['rings']} ring(s) x {info['segments']} segments, "
                           f"{info['facets']} facets, vertices on r = {info['radius']!r}"),
             "yade_wall_radius_error": info["radius_error"]}
    out = SchemaWriter(out_path, 3, n, attrs, ["small", "big"])
    out.init_profile(edges)

    prog = Progress(n, quiet)
    done = 0
    for stop in stops:
        run_steps(stop - done)
        done = stop
        if mark is not None and done == int(mark):
            prog.mark(done)
        x, v, w = states(ids, angular=stop in snap_steps)
        if not capped:
            x[:, 1] = (x[:, 1] + 0.5 * length) % length - 0.5 * length
        t = done * dt
        if stop in prof_steps:
            out.profile(t, axial_small_fraction(x[:, 1], diameter, species, edges))
        if stop in snap_steps:
            out.frame(t, done, ids, species, diameter, x, v, w)
        prog.show(f"rotation {t / period:.2f} / {total * dt / period:.2f}", done)
    prog.finish(out, total)
    return 0


if __name__ == "__main__":
    script_main(main, "drum_case.py")
