"""One thread or two: the same physics.

Forces are summed in another order with another thread count, so a drum run
on 1 and on 2 threads part after a few hundred steps (chaos). What must not
change is its statistics. On a short drum (L = 32, 5 rotations, 2 seeds, a
frame every 0.05 rotations, the first rotation left out) three observables,
in blocks of 0.5 rotations, are compared between thread counts by Welch's
t-test: the bed's tilt (the angle of its centre of mass about the axis, which
follows the surface slope), the kinetic energy per particle, and the radial
segregation (mean distance from the axis, small minus big). A race in the
force loop (a lost or doubled force) shifts all three far beyond their
spread; measured: p = 0.89, 0.65, 0.91.
"""
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from compare.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
SETS = ["drum.length=32", "run.rotations=5", "run.snapshot_every=0.05", "run.profile_every=1"]
# Three tests at once: each must reach p >= 0.001 (a family-wise false alarm rate below 0.3 %).
P_MIN = 1e-3

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")


def block_observables(path, skip_rotations=1.0, block=10):
    run = read_run(path)
    f = run.frames
    keep = f.time >= skip_rotations * run.rotation_period * (1 - 1e-9)
    m = f.diameter ** 3
    x, z = f.position[..., 0], f.position[..., 2]
    xc, zc = (m * x).sum(1) / m.sum(1), (m * z).sum(1) / m.sum(1)
    r = np.hypot(x, z)
    small = f.species == 0
    series = {
        "tilt_deg": np.degrees(np.arctan2(xc, -zc)),
        "kinetic_energy": 0.5 * (m * (f.velocity ** 2).sum(-1)).mean(1),
        "radial_segregation": (r * small).sum(1) / small.sum(1) - (r * ~small).sum(1) / (~small).sum(1),
    }
    out = {}
    for k, v in series.items():
        v = v[keep]
        nb = v.size // block
        out[k] = v[: nb * block].reshape(nb, block).mean(1)
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("threads")
    out = {}
    for seed in (1, 2):
        for threads in (1, 2):
            path = d / f"s{seed}_t{threads}.h5"
            cmd = [str(BIN), "run", str(ROOT / "scenes/drum/A.toml"), "-o", str(path), "-q",
                   "--threads", str(threads), "--set", f"particles.seed={seed}"]
            for s in SETS:
                cmd += ["--set", s]
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
            assert r.returncode == 0, r.stderr
            out[seed, threads] = block_observables(path)
    return out


@pytest.mark.parametrize("name", ["tilt_deg", "kinetic_energy", "radial_segregation"])
def test_thread_count_does_not_change_the_statistics(runs, name):
    one = np.concatenate([runs[s, 1][name] for s in (1, 2)])
    two = np.concatenate([runs[s, 2][name] for s in (1, 2)])
    assert one.size >= 14 and two.size >= 14
    p = stats.ttest_ind(one, two, equal_var=False).pvalue
    assert p >= P_MIN, (f"{name}: 1 thread {one.mean():.4g} ± {one.std():.2g}, "
                        f"2 threads {two.mean():.4g} ± {two.std():.2g}, Welch p = {p:.2g}")
