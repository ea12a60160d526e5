"""A particles scene (kind = "particles", docs/particles_scene.md) in YADE
2023.02a, run by the launcher (python3 -m yade_cases):
    yade -n -x [-jN] yade_cases/particles_case.py WORKDIR OUT.h5 [WORKDIR OUT.h5]...
Each WORKDIR holds initial.npz and case.json (yade_cases/common.py); several
pairs run one after the other in one YADE process (O.reset() between them),
which saves YADE's start-up for a batch of small scenes (compare impacts).

YADE's viscoelastic law as the native engine's contact.law = "viscel" runs it
(contact/viscel.hpp): derived["viscel_law"] (`granular init`,
scene/law_mapping.cpp map_linear_to_viscel) gives one ViscElMat per particle,
kn, cn = cn_per_mass m_i, cs = cs_per_mass m_i (ks = 0, frictionAngle = 0),
and one wall material per species, absolute; pair values mix as
1/(1/a + 1/b), 0 counting as absent. The diameters are the mapped laws'
contact diameters (2^(1/6) d), masses and moments of inertia the native
ones. Each plane wall is one fixed facet, a triangle of incircle radius 1e3
centred on the wall's point moved in by the mapped inset (2^(1/6) d_w / 2),
one facet per species present with that species' wall material, mask bits
keeping each species on its own facet (as drum_case.py's cylinders).
NewtonIntegrator(damping=0, gravity=(0, 0, -g)), O.dt = integrator.dt.
Frames at the native engine's steps (compare.schedule.particles_schedule);
their velocities are YADE's half-step velocities v(t - dt/2)."""

import json
import sys
from pathlib import Path

ROOT = Path(sys.argv[0]).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from yade import O, utils  # noqa: E402
from yade.wrapper import (ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, Bo1_Facet_Aabb,  # noqa: E402
                          InteractionLoop, Ig2_Sphere_Sphere_ScGeom, Ig2_Facet_Sphere_ScGeom,
                          Ip2_ViscElMat_ViscElMat_ViscElPhys, Law2_ScGeom_ViscElPhys_Basic, NewtonIntegrator,
                          ViscElMat)
from yade.minieigenHP import Vector3  # noqa: E402

from compare.schedule import particles_schedule  # noqa: E402
from compare.schema_writer import SchemaWriter  # noqa: E402
from yade_cases.common import read_workdir  # noqa: E402
from yade_cases.mapping import SPECIES, check_viscel_law, particle_material  # noqa: E402
from yade_cases.two_body import plane_facet_vertices  # noqa: E402
from yade_cases.yade_side import Progress, exit_with, run_steps, states, version  # noqa: E402

# As drum_case.py: small spheres 9, big 12; the small species' walls 3, the
# big's 20; avoidSelfInteractionMask 18 keeps facets from pairing.
SPHERE_MASK = {0: 9, 1: 12}
WALL_MASK = {0: 3, 1: 20}
AVOID_SELF = 18


def build(case, ini):
    s, d = case["scene"], case["derived"]
    law = d["viscel_law"]
    check_viscel_law(law)
    inset = float(d["linear_law"]["wall_inset"])
    species, mass = ini["species"].astype(int), ini["mass"]
    n = len(ini["id"])
    assert np.array_equal(ini["id"], np.arange(n)), "native ids are not 0..n-1"
    for i in range(n):  # body id k = native id k
        k = int(species[i])
        m = particle_material(law, SPECIES[k], float(mass[i]))
        di = float(ini["diameter"][i])
        rho = float(mass[i]) / (np.pi / 6.0 * di ** 3)
        mat = O.materials.append(ViscElMat(kn=m["kn"], cn=m["cn"], ks=0.0, cs=m["cs"], frictionAngle=0.0,
                                           density=rho))
        b = utils.sphere(tuple(ini["position"][i]), 0.5 * di, material=mat, mask=SPHERE_MASK[k])
        b.state.mass = float(mass[i])
        b.state.inertia = Vector3(*([float(ini["inertia"][i])] * 3))
        b.state.vel = Vector3(*ini["velocity"][i])
        b.state.angVel = Vector3(*ini["angular_velocity"][i])
        O.bodies.append(b)
    facets = 0
    for w in s.get("wall", []):
        nrm = np.asarray(w["normal"], dtype=float)
        nrm /= np.linalg.norm(nrm)
        point = np.asarray(w["point"], dtype=float) + inset * nrm
        for k in sorted(set(species.tolist())):
            wm = law["wall_materials"][SPECIES[k]]
            mat = O.materials.append(ViscElMat(kn=float(wm["kn"]), cn=float(wm["cn"]), ks=0.0, cs=float(wm["cs"]),
                                               frictionAngle=0.0, density=1.0))
            O.bodies.append(utils.facet(plane_facet_vertices(point, nrm), material=mat, fixed=True,
                                        mask=WALL_MASK[k]))
            facets += 1
    g = float(s.get("gravity", {}).get("g", 0.0))
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], avoidSelfInteractionMask=AVOID_SELF),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                        [Ip2_ViscElMat_ViscElMat_ViscElPhys()], [Law2_ScGeom_ViscElPhys_Basic()]),
        NewtonIntegrator(damping=0.0, gravity=(0, 0, -g)),
    ]
    O.dt = float(s["integrator"]["dt"])
    return {"law": law, "facets": facets, "inset": inset}


def run_one(work, out_path):
    O.reset()
    case, ini = read_workdir(work)
    s, opts = case["scene"], case["options"]
    info = build(case, ini)
    dt = float(s["integrator"]["dt"])
    total, snaps = particles_schedule(s)
    n = len(ini["id"])
    ids = np.arange(n, dtype=np.int64)
    species, diameter = ini["species"].astype(np.int32), ini["diameter"]
    attrs = {"engine": "yade", "engine_version": version(), "scene_kind": "particles", "scene_name": case["name"],
             "scene_json": case["attrs"]["scene_json"], "scene_toml": case["attrs"]["scene_toml"],
             "scene_file": case["attrs"].get("scene_file", ""),
             "contact_law": "YADE ViscElMat (Law2_ScGeom_ViscElPhys_Basic): the native contact.law = \"viscel\" "
                            "(contact/viscel.hpp), mapped from the linear law (docs/model_mapping.md)",
             "integrator": "leapfrog (YADE NewtonIntegrator, damping 0); velocities are v(t - dt/2)",
             "yade_threads": int(opts.get("threads", 1)), "yade_viscel_law": json.dumps(info["law"]),
             "yade_wall": f"{info['facets']} facet(s): one triangle (incircle radius 1e3) per wall and species, "
                          f"moved in by {info['inset']!r}"}
    out = SchemaWriter(out_path, 3, n, attrs, ["small", "big"])
    prog = Progress(n, bool(opts.get("quiet")))
    done = 0
    for stop in sorted(snaps):
        run_steps(stop - done)
        done = stop
        x, v, w = states(ids)
        out.frame(done * dt, done, ids, species, diameter, x, v, w)
        prog.show(f"t = {done * dt:.4g} / {total * dt:.4g}", done)
    prog.finish(out, total)


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        print("usage: yade -n -x yade_cases/particles_case.py WORKDIR OUT.h5 [WORKDIR OUT.h5]...", file=sys.stderr)
        return 2
    for k in range(0, len(argv), 2):
        run_one(argv[k], argv[k + 1])
    return 0


if __name__ == "__main__":
    exit_with(lambda: main(sys.argv[1:]))
