"""Poeschel and Herrmann's shaken box in YADE 2023.02a, run by the launcher
(python3 -m yade_cases):
    yade -n -x [-jN] yade_cases/box_case.py WORKDIR OUT.h5
WORKDIR holds initial.npz and case.json (yade_cases/common.py).

Disks as spheres in the plane z = 0 with blockedDOFs = 'zXY', masses
(2 pi R^2 rho) and moments of inertia (1/2 m R^2) from the native initial
state; one ViscElMat per particle (kn = 2 Y, cn = gamma_N m_i,
cs = gamma_S m_i, frictionAngle = 0: the paper's law with normal-component
damping and without its Coulomb cap, yade_cases/mapping.py); gravity along -y;
NewtonIntegrator(damping=0). The wall particles are ordinary spheres with
their native masses and the same per-particle material, joined in one
non-dynamic clump (so they never interact with each other, and one body
carries the motion): a PyRunner before the NewtonIntegrator sets the clump at
y_box(t_k) with the velocity (y_box(t_k+1) - y_box(t_k))/dt each step, so the
integrator puts every wall particle at its anchor + y_box(t_k+1), the closed
form of integrate/motion.hpp (ShakerMotion: start-up envelope, frequency
ramp), to round-off."""

import math
import sys
from pathlib import Path

ROOT = Path(sys.argv[0]).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from yade import O, utils  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402
from yade.wrapper import (ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, InteractionLoop,  # noqa: E402
                          Ig2_Sphere_Sphere_ScGeom, Ip2_ViscElMat_ViscElMat_ViscElPhys,
                          Law2_ScGeom_ViscElPhys_Basic, NewtonIntegrator, PyRunner, ViscElMat)

from compare.schema_writer import SchemaWriter  # noqa: E402
from compare.schedule import Shaker, box_schedule  # noqa: E402
from yade_cases.common import read_workdir  # noqa: E402
from yade_cases.mapping import box_material  # noqa: E402
from yade_cases.yade_side import Progress, forces, run_steps, states, version, script_main  # noqa: E402

# Grains (and the big disk) mask 3, wall particles 5; avoidSelfInteractionMask 4
# keeps wall particles (same mask) from pairing; 3 & 5 = 1 lets grains touch walls.
GRAIN_MASK, WALL_MASK, AVOID_SELF = 3, 5, 4
WALL = 2

SHAKE = {}  # the PyRunner's state: clump, anchor, shaker, dt


def shake():
    """PyRunner, before the NewtonIntegrator, at iteration k (time k dt)."""
    k, dt, sh = O.iter, SHAKE["dt"], SHAKE["shaker"]
    y0, y1 = sh.y(k * dt), sh.y((k + 1) * dt)
    st = SHAKE["clump"].state
    a = SHAKE["anchor"]
    st.pos = Vector3(a[0], a[1] + y0, a[2])
    st.vel = Vector3(0.0, (y1 - y0) / dt, 0.0)


def build(case, ini):
    s = case["scene"]
    dt, g = float(s["integrator"]["dt"]), float(s["gravity"]["g"])
    n = len(ini["id"])
    assert np.array_equal(ini["id"], np.arange(n)), "native ids are not 0..n-1"
    species, mass = ini["species"].astype(int), ini["mass"]
    pos = np.zeros((n, 3))
    pos[:, :2] = ini["position"]
    wall_ids = []
    for i in range(n):
        k = int(species[i])
        m = box_material(s, k, float(mass[i]))
        r = 0.5 * float(ini["diameter"][i])
        rho = float(mass[i]) / (4.0 / 3.0 * math.pi * r ** 3)
        mat = O.materials.append(ViscElMat(kn=m["kn"], cn=m["cn"], ks=0.0, cs=m["cs"], frictionAngle=0.0, density=rho))
        b = utils.sphere(tuple(pos[i]), r, material=mat, mask=WALL_MASK if k == WALL else GRAIN_MASK)
        if k != WALL:
            b.state.blockedDOFs = "zXY"
            b.state.vel = Vector3(float(ini["velocity"][i][0]), float(ini["velocity"][i][1]), 0.0)
            b.state.angVel = Vector3(0.0, 0.0, float(ini["angular_velocity"][i][0]))
        bid = O.bodies.append(b)
        assert bid == i
        if k == WALL:
            wall_ids.append(i)
    clump = None
    if wall_ids:
        cid = O.bodies.clump(wall_ids)
        clump = O.bodies[cid]
        clump.dynamic = False
        clump.state.vel = Vector3(0, 0, 0)
        clump.state.angVel = Vector3(0, 0, 0)
    # native masses and inertia (the clump's own are not used: it is not integrated)
    for i in range(n):
        st = O.bodies[i].state
        st.mass = float(mass[i])
        st.inertia = Vector3(*([float(ini["inertia"][i])] * 3))
    SHAKE.update(clump=clump, anchor=tuple(clump.state.pos) if clump else None, shaker=Shaker(s), dt=dt)

    engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()], avoidSelfInteractionMask=AVOID_SELF),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_ViscElMat_ViscElMat_ViscElPhys()],
                        [Law2_ScGeom_ViscElPhys_Basic()]),
    ]
    if clump is not None:
        engines.append(PyRunner(iterPeriod=1, command="shake()"))
    engines.append(NewtonIntegrator(damping=0.0, gravity=(0, -g, 0)))
    O.engines = engines
    O.dt = dt
    return len(wall_ids)


def main(work, out_path):
    case, ini = read_workdir(work)
    s = case["scene"]
    opts = case["options"]
    quiet = bool(opts.get("quiet"))
    n_wall = build(case, ini)
    box, sh = s["box"], s["shaking"]
    dt = float(s["integrator"]["dt"])
    shaker = SHAKE["shaker"]
    total, settle_steps, snaps, traces = box_schedule(s)
    stops = sorted(snaps | traces)
    mark = opts.get("timed_from_step")
    if mark is not None:
        stops = sorted(set(stops) | {int(mark)})

    n = len(ini["id"])
    ids = np.arange(n, dtype=np.int64)
    species, diameter = ini["species"].astype(np.int32), ini["diameter"]
    big = np.flatnonzero(species == 1)
    attrs = {"engine": "yade", "engine_version": version(), "scene_kind": "shaken_box", "scene_name": case["name"],
             "scene_json": case["attrs"]["scene_json"], "scene_toml": case["attrs"]["scene_toml"],
             "scene_file": case["attrs"].get("scene_file", ""), "frequency": float(sh["frequency"]),
             "amplitude": float(sh["amplitude"]), "settle": float(s["run"]["settle"]),
             "box_width": float(box["width"]), "wall_radius": float(box["wall_radius"]),
             "integrator": "leapfrog (YADE NewtonIntegrator, damping 0)",
             "contact_law": "YADE ViscElMat (Law2_ScGeom_ViscElPhys_Basic): kn = Y, cn = gamma_N m_eff, "
                            "cs = gamma_S m_eff per pair, normal force clipped at 0, tangential force not capped",
             "yade_threads": int(opts.get("threads", 1)),
             "yade_wall_motion": (f"{n_wall} wall particles in one non-dynamic clump; PyRunner every step sets "
                                  "y_box(t_k) and the chord velocity to y_box(t_k+1) (integrate/motion.hpp)"),
             "yade_force": "contact force of the last step (YADE evaluates it before the step's move)"}
    out = SchemaWriter(out_path, 2, n, attrs, ["small", "big", "wall"], with_force=True)
    if len(big):
        out.init_series("trace", {"time": 0, "cycle": 0, "box_y": 0, "big_position": 2, "big_velocity": 2})

    prog = Progress(n, quiet)
    done = 0
    for stop in stops:
        run_steps(stop - done)
        done = stop
        if mark is not None and done == int(mark):
            prog.mark(done)
        t = done * dt
        if stop in snaps:
            xs, vs, ws = states(ids)
            out.frame(t, done, ids, species, diameter, xs, vs, ws, forces(ids))
        if stop in traces and len(big):
            xb, vb, _ = states(big[:1], angular=False)
            out.series(time=t, cycle=shaker.cycle(t), box_y=shaker.y(t), big_position=xb[0, :2],
                       big_velocity=vb[0, :2])
        prog.show(f"t = {t:.2f} / {total * dt:.2f} s", done)
    prog.finish(out, total)
    return 0


if __name__ == "__main__":
    script_main(main, "box_case.py")
