"""A few particles (and optionally one flat facet) under YADE's ViscElMat law,
stepped by YADE, trajectory written as JSON: the YADE side of two-body
agreement tests, like the native helper build/tests/native/two_body
(tests/native/two_body.cpp), with the same output layout.

    yade -n -x yade_cases/two_body.py IN.json OUT.json

IN: {"dim": 2 | 3, "dt", "steps", "gravity": [..dim..],
     "particles": [{"x", "v", "w", "d", "m", "I", "material": {"kn", "cn", "cs"}}],
     "wall": {"kind": "facet", "point", "normal", "velocity", "material": {"kn", "cn", "cs"}}  (optional)}
  x, v have dim components; w has 1 (2D: about z) or 3; the material values
  are a ViscElMat's (pair value 1/(1/a + 1/b), 0 = absent; ks = 0,
  frictionAngle = 0). 2D: spheres in the plane z = 0 with blockedDOFs 'zXY'.
  The wall is one large triangular facet through "point" with that normal
  (its incircle radius 1e3 around the point: no edge within reach), moving at
  the constant "velocity" (tangential to it, or it would leave its plane).
OUT: [step][particle] -> [x..., v..., w...] after each of the steps, particles
  in input order (2D: x, y, vx, vy, wz; 3D: 3 + 3 + 3).

From plain Python: yade_cases.two_body.run(setup) -> np.ndarray
(steps, particles, values), through the `yade` launcher."""

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent if "__file__" in globals() and not str(__file__).endswith("/yade") \
    else Path(sys.argv[0]).resolve().parent


def run(setup: dict, timeout: float = 300.0) -> np.ndarray:
    """Runs setup in YADE (yade -n -x two_body.py) and returns (steps, particles, values)."""
    yade = shutil.which("yade")
    if yade is None:
        raise RuntimeError("`yade` is not on PATH (apt-get install yade; scripts/setup.sh)")
    with tempfile.TemporaryDirectory(prefix="yade_two_body_") as tmp:
        inp, out = Path(tmp) / "in.json", Path(tmp) / "out.json"
        inp.write_text(json.dumps(setup))
        res = subprocess.run([yade, "-n", "-x", "-j1", str(HERE / "two_body.py"), str(inp), str(out)],
                             capture_output=True, text=True, timeout=timeout,
                             env=dict(os.environ, OMP_NUM_THREADS="1"))
        if res.returncode != 0 or not out.exists():
            raise RuntimeError(f"yade two_body failed ({res.returncode}):\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}")
        return np.array(json.loads(out.read_text()))


def plane_facet_vertices(point, normal, incircle=1e3):
    """The vertices of one triangle in the plane through POINT with that
    normal, its incircle (radius INCIRCLE) centred on the point: a plane wall
    with no edge within reach of the particles near the point."""
    p, nrm = np.asarray(point, dtype=float), np.asarray(normal, dtype=float)
    nrm = nrm / np.linalg.norm(nrm)
    u = np.cross(nrm, [1.0, 0.0, 0.0] if abs(nrm[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(nrm, u)
    big = 2.0 * incircle  # circumradius of an equilateral triangle
    return [tuple(p + big * (math.cos(a) * u + math.sin(a) * v)) for a in (0.0, 2 * math.pi / 3, 4 * math.pi / 3)]


def _simulate(setup: dict) -> list:
    from yade import O, utils
    from yade.minieigenHP import Vector3
    from yade.wrapper import (ForceResetter, InsertionSortCollider, Bo1_Sphere_Aabb, Bo1_Facet_Aabb,
                              InteractionLoop, Ig2_Sphere_Sphere_ScGeom, Ig2_Facet_Sphere_ScGeom,
                              Ip2_ViscElMat_ViscElMat_ViscElPhys, Law2_ScGeom_ViscElPhys_Basic,
                              NewtonIntegrator, ViscElMat)

    dim = int(setup["dim"])
    pad = lambda a: [float(c) for c in a] + [0.0] * (3 - len(a))  # noqa: E731

    def material(m, density=1.0):
        return O.materials.append(ViscElMat(kn=float(m["kn"]), cn=float(m["cn"]), ks=0.0, cs=float(m["cs"]),
                                            frictionAngle=0.0, density=density))

    ids = []
    for q in setup["particles"]:
        r = 0.5 * float(q["d"])
        b = utils.sphere(pad(q["x"]), r, material=material(q["material"], float(q["m"]) / (4 / 3 * math.pi * r ** 3)))
        w = [0.0, 0.0, float(q["w"][0])] if dim == 2 else pad(q["w"])
        b.state.vel = Vector3(*pad(q["v"]))
        b.state.angVel = Vector3(*w)
        if dim == 2:
            b.state.blockedDOFs = "zXY"
        ids.append(O.bodies.append(b))
        st = O.bodies[ids[-1]].state
        st.mass = float(q["m"])
        st.inertia = Vector3(*([float(q["I"])] * 3))
    wall = setup.get("wall")
    if wall:
        if wall.get("kind", "facet") != "facet":
            raise ValueError(f"wall.kind = {wall['kind']!r}: only \"facet\"")
        verts = plane_facet_vertices(pad(wall["point"]), pad(wall["normal"]))
        f = utils.facet(verts, material=material(wall["material"]), fixed=True)
        fid = O.bodies.append(f)
        O.bodies[fid].state.vel = Vector3(*pad(wall.get("velocity", [0.0] * dim)))
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                        [Ip2_ViscElMat_ViscElMat_ViscElPhys()], [Law2_ScGeom_ViscElPhys_Basic()]),
        NewtonIntegrator(damping=0.0, gravity=pad(setup.get("gravity", [0.0] * dim))),
    ]
    O.dt = float(setup["dt"])
    rows = []
    for _ in range(int(setup["steps"])):
        O.step()
        row = []
        for i in ids:
            st = O.bodies[i].state
            x, vel, w = list(st.pos), list(st.vel), list(st.angVel)
            row.append(x[:dim] + vel[:dim] + ([w[2]] if dim == 2 else w))
        rows.append(row)
    return rows


def main(argv) -> int:
    if len(argv) != 2:
        print("usage: yade -n -x yade_cases/two_body.py IN.json OUT.json", file=sys.stderr)
        return 2
    setup = json.loads(Path(argv[0]).read_text())
    rows = _simulate(setup)
    Path(argv[1]).write_text(json.dumps(rows))
    return 0


def _in_yade() -> bool:
    try:
        import yade.wrapper  # noqa: F401
        return True
    except ImportError:
        return False


if __name__ == "__main__":
    if not _in_yade():
        print("two_body.py runs inside YADE: yade -n -x yade_cases/two_body.py IN.json OUT.json "
              "(or yade_cases.two_body.run(setup) from Python)", file=sys.stderr)
        sys.exit(2)
    if str(HERE.parent) not in sys.path:
        sys.path.insert(0, str(HERE.parent))
    from yade_cases.yade_side import exit_with
    exit_with(lambda: main(sys.argv[1:]))
