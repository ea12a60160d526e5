"""Tests for compare.box (shaken-box observables) on synthetic runs and one short native run."""

import json
import math
import subprocess
from pathlib import Path

import h5py
import matplotlib
import numpy as np
import pytest
from scipy.stats import beta, binom

matplotlib.use("Agg")

from compare.box import (BigDiskHeight, ConvectiveFlux, ForceRatio, Shaker, VelocityField,  # noqa: E402
                         bed_height, node_frames, observe_box, onset_fraction, onset_threshold,
                         read_forces, read_trace, settled_frame)
from compare.reader import read_run  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[2]
GRANULAR = REPO_ROOT / "build" / "granular"
FREQ = 2.0      # Hz; synthetic runs
SETTLE = 1.0    # s
WIDTH = 30.0    # cm
AMP = 2.0       # cm


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt
    plt.close("all")


def write_box_run(path, times, positions, species, diameter, force=None, trace=None, ids=None,
                  settle=SETTLE, frequency=FREQ, width=WIDTH, amplitude=AMP, startup_cycles=0.0):
    """A shaken-box run in the granular-frames layout of the native engine.

    positions (F, N, 2); species, diameter (N,) or (F, N); force (F, N, 2) or None;
    trace: dict of /trace datasets or None; ids: (F, N) column order as written."""
    positions = np.asarray(positions, dtype=np.float64)
    F, N, _ = positions.shape
    times = np.asarray(times, dtype=np.float64)
    species = np.broadcast_to(species, (F, N)).astype(np.int32)
    diameter = np.broadcast_to(diameter, (F, N)).astype(np.float64)
    force = np.zeros_like(positions) if force is None else np.asarray(force, dtype=np.float64)
    if ids is None:
        ids = np.broadcast_to(np.arange(N), (F, N))
    ids = np.asarray(ids, dtype=np.int64)
    # write columns in the given id order: column j of frame f holds particle ids[f, j]
    take = lambda a: np.take_along_axis(a, ids if a.ndim == 2 else ids[:, :, None], axis=1)  # noqa: E731
    duration = float(times[-1] - settle) if F else 0.0
    scene = {"scene": {"kind": "shaken_box", "name": "synthetic"},
             "box": {"width": width, "wall_radius": 1.0, "wall_height": 100.0, "wall_spacing": 2.0},
             "shaking": {"amplitude": amplitude, "frequency": frequency, "ramp_to": frequency, "ramp_start": 0.0,
                         "ramp_time": 0.0, "startup_cycles": startup_cycles},
             "run": {"settle": settle, "duration": duration, "snapshot_every_cycles": 1.0, "trace_per_cycle": 20}}
    root = {"schema": "granular-frames", "schema_version": 1, "engine": "synthetic", "engine_version": "0",
            "scene_kind": "shaken_box", "scene_name": "synthetic", "dim": 2, "scene_json": json.dumps(scene),
            "frequency": frequency, "amplitude": amplitude, "settle": settle, "box_width": width,
            "wall_radius": 1.0}
    with h5py.File(path, "w") as h5:
        for k, v in root.items():
            h5.attrs[k] = v
        g = h5.create_group("frames")
        g.attrs["species_names"] = ["small", "big", "wall"]
        g["time"] = times
        g["step"] = np.rint(times / 5e-5).astype(np.int64)
        g["id"] = ids
        g["species"] = take(species)
        g["diameter"] = take(diameter)
        g["position"] = take(positions)
        g["velocity"] = np.zeros_like(positions)
        g["angular_velocity"] = np.zeros((F, N, 1))
        g["force"] = take(force)
        if trace is not None:
            t = h5.create_group("trace")
            for k, v in trace.items():
                t[k] = np.asarray(v, dtype=np.float64)
    return path


def node_times(n_cycles, frequency=FREQ, settle=SETTLE):
    """t = 0, end of settling, then nodes 1..n_cycles."""
    return np.r_[0.0, settle, settle + np.arange(1, n_cycles + 1) / frequency]


# ------------------------------------------------------------------ (a) big-disk height

H_BED = 30.0   # bed height of the synthetic big-disk runs
R_BIG = 4.0


def big_run(path, h_of_t, seconds=20.0, per_cycle=20, n_small=40):
    """Trace with h(t_s) given; small disks whose tops are all at H_BED in the settled frame."""
    ts = np.arange(1, int(seconds * FREQ * per_cycle) + 1) / (FREQ * per_cycle)
    h = h_of_t(ts)
    yb = AMP * np.sin(2 * np.pi * FREQ * ts)
    trace = {"time": SETTLE + ts, "cycle": ts * FREQ, "box_y": yb,
             "big_position": np.stack([np.zeros_like(ts), h + R_BIG + yb], axis=1),
             "big_velocity": np.zeros((ts.size, 2))}
    times = node_times(3)
    n = n_small + 1
    species = np.r_[np.zeros(n_small), 1]
    diameter = np.r_[np.full(n_small, 2.0), 2 * R_BIG]
    pos = np.zeros((times.size, n, 2))
    pos[:, :n_small, 0] = np.linspace(-14, 14, n_small)
    pos[:, :n_small, 1] = H_BED - 1.0
    pos[:, -1, 1] = R_BIG
    return write_box_run(path, times, pos, species, diameter, trace=trace), ts[1] - ts[0]


def rise(ts, wait=10.0, duration=5.0):
    top = H_BED - 2 * R_BIG
    return top * np.clip((ts - wait) / duration, 0.0, 1.0)


def test_big_disk_waiting_and_rise_time(tmp_path):
    path, dt = big_run(tmp_path / "rise.h5", rise)
    b = BigDiskHeight().compute(read_run(path))
    assert b.bed_height == pytest.approx(H_BED)
    assert b.top_height == pytest.approx(H_BED - 2 * R_BIG)
    assert b.start_height == pytest.approx(0.0, abs=1e-9)
    assert b.reached_top
    assert b.waiting_time_s == pytest.approx(10.0, abs=dt)
    assert b.rise_time_s == pytest.approx(5.0, abs=dt)
    assert b.height[0] == pytest.approx(0.0, abs=1e-9)  # box motion removed: h = y - R - y_box
    assert b.times_s[0] == pytest.approx(dt)
    d = b.as_dict()
    json.dumps(d)
    assert d["reached_top"] is True and d["cycle_mean_height"][-1] == pytest.approx(H_BED - 2 * R_BIG)
    b.plot()


def test_big_disk_false_start_and_bounce_are_ignored(tmp_path):
    top = H_BED - 2 * R_BIG

    def h(ts):  # bounces within each cycle, a false start to 40 % at 4-6 s, then the real rise
        bump = 0.4 * top * np.clip(1 - np.abs(ts - 5.0), 0, None)
        bounce = 0.5 * np.abs(np.sin(2 * np.pi * FREQ * ts))
        return rise(ts, wait=12.0, duration=4.0) + bump + bounce

    path, dt = big_run(tmp_path / "false.h5", h)
    b = BigDiskHeight().compute(read_run(path))
    assert b.reached_top
    # the one-cycle mean of the bounce is a constant offset 1/pi of its amplitude
    off = 0.5 * 2 / math.pi
    assert 0.0 < b.start_height < 0.5
    expected_wait = 12.0 + 4.0 * (b.start_height - off) / top  # z=0 of the normalised rise
    assert b.waiting_time_s == pytest.approx(expected_wait, abs=3 * dt)
    assert b.rise_time_s == pytest.approx(4.0 * (top - b.start_height) / top, abs=3 * dt)
    assert b.waiting_time_s > 10.0  # not the false start at 4 s


def test_big_disk_never_rises(tmp_path):
    path, _ = big_run(tmp_path / "flat.h5", lambda ts: 0.3 * np.abs(np.sin(2 * np.pi * FREQ * ts)))
    b = BigDiskHeight().compute(read_run(path))
    assert b.reached_top is False
    assert b.waiting_time_s is None and b.rise_time_s is None
    assert b.as_dict()["waiting_time_s"] is None


def test_big_disk_needs_trace(tmp_path):
    path = write_box_run(tmp_path / "notrace.h5", node_times(2), np.zeros((4, 2, 2)), [0, 1], [2.0, 8.0])
    run = read_run(path)
    assert read_trace(run) is None
    with pytest.raises(ValueError, match="trace"):
        BigDiskHeight().compute(run)


# ------------------------------------------------------------------ (b) convective flux

def conveyor_run(path, n_c, n_w, cycles=8, lines=80, direction=1, n_wall_species=1):
    """Columns of disks one line spacing apart; centre columns move up one
    spacing per cycle, wall columns down (direction=-1 reverses, 0 = no motion).
    Settled frame: every small disk's top at H_BED (so H = H_BED)."""
    s = H_BED / lines
    P = cycles
    cols = []  # (x, species, start heights, step per cycle)
    for x in np.linspace(-3, 3, n_c):
        cols.append((x, 0, (np.arange(-P - 2, lines + P + 3) + 0.25) * s, direction * s))
    for k in range(n_w):
        x = (11.0 + k) * (1 if k % 2 == 0 else -1)
        cols.append((x, 0, (np.arange(-P - 2, lines + P + 3) + 0.75) * s, -direction * s))
    for _ in range(n_wall_species):  # wall particles in the centre moving up: must not count
        cols.append((0.5, 2, (np.arange(-P - 1, lines + 1) + 0.25) * s, s))
    x = np.concatenate([np.full(c[2].size, c[0]) for c in cols])
    sp = np.concatenate([np.full(c[2].size, c[1]) for c in cols])
    y0 = np.concatenate([c[2] for c in cols])
    step = np.concatenate([np.full(c[2].size, c[3]) for c in cols])
    times = node_times(cycles)
    pos = np.zeros((times.size, x.size, 2))
    pos[:, :, 0] = x
    pos[0, :, 1] = H_BED + 5.0
    pos[1, :, 1] = H_BED - 0.5  # settled: tops (d = 1) at H_BED
    for n in range(1, cycles + 1):
        pos[n + 1, :, 1] = y0 + (n - 1) * step
    return write_box_run(path, times, pos, sp, 1.0)


def test_flux_conveyor(tmp_path):
    n_c, n_w = 3, 2
    run = read_run(conveyor_run(tmp_path / "conv.h5", n_c, n_w))
    c = ConvectiveFlux(skip_cycles=0).compute(run)
    assert c.heights.size == 80
    assert c.spacing == pytest.approx(H_BED / 80)
    assert c.heights[0] == pytest.approx(0.5 * c.spacing) and c.heights[-1] == pytest.approx(H_BED - 0.5 * c.spacing)
    assert c.pairs_used == 7 and c.cycles_used == 7
    np.testing.assert_allclose(c.j_centre, n_c)
    np.testing.assert_allclose(c.j_wall, -n_w)
    np.testing.assert_allclose(c.phi, n_c + n_w)
    np.testing.assert_allclose(c.phi_se, 0.0)
    assert c.phi_max == pytest.approx(n_c + n_w)
    assert c.lowest_height == pytest.approx(c.heights[0])
    assert c.depth == pytest.approx(H_BED - 0.5 * c.spacing)
    json.dumps(c.as_dict())
    c.plot()


def test_flux_skip_and_window(tmp_path):
    run = read_run(conveyor_run(tmp_path / "conv.h5", 2, 2, cycles=10))
    assert ConvectiveFlux(skip_cycles=5).compute(run).pairs_used == 5   # pairs (5,6) .. (9,10)
    assert ConvectiveFlux(skip_cycles=2, max_cycles=3).compute(run).pairs_used == 3


def test_flux_reversed_and_still(tmp_path):
    rev = ConvectiveFlux(skip_cycles=0).compute(read_run(conveyor_run(tmp_path / "rev.h5", 2, 2, direction=-1)))
    np.testing.assert_allclose(rev.phi, -4.0)
    assert rev.depth is None and rev.lowest_height is None
    still = ConvectiveFlux(skip_cycles=0).compute(read_run(conveyor_run(tmp_path / "still.h5", 2, 2, direction=0)))
    np.testing.assert_allclose(still.phi, 0.0)
    np.testing.assert_allclose(still.j_centre, 0.0)
    assert still.depth is None


def loop_position(u, x0=3.0, x1=12.0, y1=15.0, y2=28.0):
    """Point at arc length u on the rectangular loop up x = x0, across the top
    to x1, down x = x1, back along y1 (one convection roll, x > 0)."""
    a, b = y2 - y1, x1 - x0
    u = np.mod(u, 2 * (a + b))
    x = np.select([u < a, u < a + b, u < 2 * a + b], [np.full_like(u, x0), x0 + (u - a), np.full_like(u, x1)],
                  x1 - (u - 2 * a - b))
    y = np.select([u < a, u < a + b, u < 2 * a + b], [y1 + u, np.full_like(u, y2), y2 - (u - a - b)],
                  np.full_like(u, y1))
    return x, y


def test_flux_significance_is_local_to_the_roll(tmp_path):
    """Two rolls in the upper half (y 15..28), random jitter in the lower half:
    the significant region starts just above y = 15."""
    rng = np.random.default_rng(3)
    lines, cycles, s = 40, 30, H_BED / 40
    n_roll, n_low = 200, 300
    u = rng.uniform(0, 44.0, n_roll)
    side = np.where(np.arange(n_roll) % 2 == 0, 1.0, -1.0)
    xl, yl = rng.uniform(-14, 14, n_low), rng.uniform(0.5, 14.0, n_low)
    times = node_times(cycles)
    n = n_roll + n_low
    pos = np.zeros((times.size, n, 2))
    pos[0:2, :, 1] = H_BED - 0.5  # settled frame: tops at H_BED
    for k in range(1, cycles + 1):
        x, y = loop_position(u + 1.5 * k)
        pos[k + 1, :n_roll] = np.stack([side * x, y], axis=1)
        pos[k + 1, n_roll:, 0] = xl
        pos[k + 1, n_roll:, 1] = yl + rng.choice([-0.4, 0.4], n_low) * s
    run = read_run(write_box_run(tmp_path / "half.h5", times, pos, 0, 1.0))
    c = ConvectiveFlux(lines=lines, skip_cycles=0).compute(run)
    assert c.phi_max > 10  # 2 rolls x 100/44 per cm x 1.5 cm per cycle, up and down: 13.6
    assert c.lowest_height == pytest.approx(15.0 + 0.5 * s)
    assert c.depth == pytest.approx(H_BED - 15.0 - 0.5 * s)
    low = c.heights < 15.0
    assert np.all(np.abs(c.phi[low]) <= 5 * c.phi_se[low])
    assert np.all(c.j_centre[(c.heights > 16) & (c.heights < 27)] > 0)
    assert np.all(c.j_wall[(c.heights > 16) & (c.heights < 27)] < 0)


# ------------------------------------------------------------------ (c) velocity field

def test_velocity_field_uniform_drift(tmp_path):
    gx, gy = np.meshgrid(np.linspace(-14.0, 14.0, 30), np.linspace(1.0, 29.0, 29))
    base = np.stack([gx.ravel(), gy.ravel()], axis=1)
    n = base.shape[0]
    cycles = 12
    drift = np.array([0.05, -0.08])  # cm per cycle
    times = node_times(cycles)
    pos = np.zeros((times.size, n, 2))
    pos[0] = base
    pos[1] = base
    for k in range(1, cycles + 1):
        pos[k + 1] = base + (k - 1) * drift
    species = np.where(np.arange(n) == 0, 1, 0)  # the big disk counts as well
    run = read_run(write_box_run(tmp_path / "drift.h5", times, pos, species, 1.0))
    v = VelocityField(cells=(6, 5), periods=4, height=30.0).compute(run)
    assert v.periods_used == 4
    assert v.velocity.shape == (5, 6, 2)
    assert np.all(v.count > 0)
    np.testing.assert_allclose(v.velocity[..., 0], drift[0] * FREQ, rtol=1e-9)
    np.testing.assert_allclose(v.velocity[..., 1], drift[1] * FREQ, rtol=1e-9)
    assert v.count.sum() == 4 * n
    assert v.centre_vy == pytest.approx(drift[1] * FREQ)
    assert v.mean_speed == pytest.approx(np.hypot(*drift) * FREQ)
    json.dumps(v.as_dict())
    v.plot()
    # all pairs after skip_cycles when periods exceeds them
    assert VelocityField(periods=50, skip_cycles=5).compute(run).periods_used == cycles - 5


def test_velocity_field_roll_signs(tmp_path):
    """Up in the centre, down at the walls: centre_vy > 0 > wall_vy."""
    xs = np.r_[np.linspace(-3, 3, 10), np.linspace(10, 14, 5), np.linspace(-14, -10, 5)]
    up = np.abs(xs) < 7.5
    times = node_times(8)
    pos = np.zeros((times.size, xs.size, 2))
    pos[:, :, 0] = xs
    for k in range(times.size):
        pos[k, :, 1] = 10 + np.where(up, 0.1, -0.1) * k
    v = VelocityField(periods=10, skip_cycles=0, min_count=1).compute(
        read_run(write_box_run(tmp_path / "roll.h5", times, pos, 0, 1.0)))
    assert v.centre_vy == pytest.approx(0.1 * FREQ)
    assert v.wall_vy == pytest.approx(-0.1 * FREQ)


# ------------------------------------------------------------------ (d) force ratio

def ring(c, r=6.0, n=8):
    a = 2 * np.pi * np.arange(n) / n
    return np.stack([c[0] + r * np.cos(a), c[1] + r * np.sin(a)], axis=1)


def force_runs(tmp_path, f_with=2.0, f_without=1.6, cycles=8):
    """Big disk alternating between A=(0,10) and B=(0,30); rings of 8 small disks
    around both places.  In the big run the ring round the big disk carries
    f_with, the other ring 100; in the reference the ring at the big run's big
    disk position of the same cycle carries f_without, the other 100.  A wall
    particle with a huge force sits in each ring (must be ignored)."""
    A, B = np.array([0.0, 10.0]), np.array([0.0, 30.0])
    small = np.r_[ring(A), ring(B), ring(A)[:1] + [0.5, 0], ring(B)[:1] + [0.5, 0]]
    sp_small = np.r_[np.zeros(16), 2, 2]
    times = node_times(cycles)
    F = times.size
    where = [A if (k % 2) else B for k in range(F)]  # frame k is cycle k-1 for k >= 2
    fmag = lambda k, val: np.r_[np.where(np.all(where[k] == A), val, 100.0) * np.ones(8),  # noqa: E731
                                np.where(np.all(where[k] == B), val, 100.0) * np.ones(8), 1e6, 1e6]
    pos_b = np.zeros((F, 19, 2))
    force_b = np.zeros((F, 19, 2))
    pos_r = np.zeros((F, 18, 2))
    force_r = np.zeros((F, 18, 2))
    for k in range(F):
        pos_b[k, :18] = small
        pos_b[k, 18] = where[k]
        force_b[k, :18, 1] = fmag(k, f_with)
        pos_r[k] = small
        force_r[k, :, 0] = fmag(k, f_without)
    rng = np.random.default_rng(0)
    ids = np.array([rng.permutation(19) for _ in range(F)])  # columns written out of id order
    big = write_box_run(tmp_path / "big.h5", times, pos_b, np.r_[sp_small, 1], np.r_[np.full(18, 2.0), 8.0],
                        force=force_b, ids=ids)
    ref = write_box_run(tmp_path / "ref.h5", times, pos_r, sp_small, 2.0, force=force_r)
    return read_run(big), read_run(ref)


def test_force_ratio_known(tmp_path):
    big, ref = force_runs(tmp_path)
    forces = read_forces(big)
    assert forces.shape == big.frames.position.shape
    fr = ForceRatio(skip_cycles=1).compute(big, reference=ref)
    assert fr.mean_with == pytest.approx(2.0)
    assert fr.mean_without == pytest.approx(1.6)
    assert fr.ratio == pytest.approx(1.25)
    assert fr.frames_with == 8 and fr.frames_without == 8
    json.dumps(fr.as_dict())
    fr.plot()
    alone = ForceRatio(skip_cycles=1).compute(big)
    assert alone.mean_with == pytest.approx(2.0) and alone.ratio is None
    # a reference given as a path works the same
    assert ForceRatio(skip_cycles=1).compute(big, reference=ref.path).ratio == pytest.approx(1.25)
    # ring at the mean position (0, 20) instead: it catches the 100-dyn disks
    assert ForceRatio(skip_cycles=1, match="mean").compute(big, reference=ref).ratio != pytest.approx(1.25)


def test_force_ratio_needs_big_disk(tmp_path):
    _, ref = force_runs(tmp_path)
    with pytest.raises(ValueError, match="big disk"):
        ForceRatio().compute(ref)


# ------------------------------------------------------------------ (e) onset frequency

def test_onset_fraction_clopper_pearson():
    f, lo, hi = onset_fraction([True, True, False, True, False, True])
    assert f == pytest.approx(4 / 6)
    assert lo == pytest.approx(beta.ppf(0.025, 4, 3)) and hi == pytest.approx(beta.ppf(0.975, 5, 2))
    assert lo < 4 / 6 < hi
    assert onset_fraction([True] * 6) == pytest.approx((1.0, 0.025 ** (1 / 6), 1.0))
    assert onset_fraction([False] * 6)[1] == 0.0
    with pytest.raises(ValueError):
        onset_fraction([])


@pytest.mark.parametrize("p_true", [0.1, 0.3, 0.5, 0.8])
def test_onset_fraction_interval_covers_true_fraction(p_true):
    """Exact coverage of the interval over all outcomes of 6 packings is >= 95 %."""
    n = 6
    cover = sum(binom.pmf(k, n, p_true) for k in range(n + 1)
                if (lambda r: r[1] <= p_true <= r[2])(onset_fraction([True] * k + [False] * (n - k))))
    assert cover >= 0.95


def test_onset_threshold_linear():
    freqs = [2.5, 2.6, 2.7, 2.8, 2.9, 3.0]
    r = onset_threshold(freqs, [0, 2, 4, 6, 8, 10], [10] * 6)
    assert r["threshold"] == pytest.approx(2.75)
    assert r["threshold_position"] == "in_grid"
    assert r["lo"] < 2.75 < r["hi"]
    json.dumps(r)


def test_onset_threshold_interval_from_bounds():
    freqs = [3.2, 2.6, 3.0, 2.8]                       # unsorted on purpose
    r = onset_threshold(freqs, [6, 0, 5, 2], [6, 6, 6, 6])
    assert r["freqs"] == [2.6, 2.8, 3.0, 3.2]
    assert r["threshold"] == pytest.approx(2.8 + (0.5 - 1 / 3) / (5 / 6 - 1 / 3) * 0.2)
    hi0, hi1 = beta.ppf(0.975, 1, 6), beta.ppf(0.975, 3, 4)   # upper bounds at 0/6 and 2/6
    assert r["lo"] == pytest.approx(2.6 + (0.5 - hi0) / (hi1 - hi0) * 0.2)
    lo2, lo3 = beta.ppf(0.025, 5, 2), 0.025 ** (1 / 6)      # lower bounds at 5/6 and 6/6
    assert r["hi"] == pytest.approx(3.0 + (0.5 - lo2) / (lo3 - lo2) * 0.2)
    assert 2.6 < r["lo"] < r["threshold"] < r["hi"] < 3.2


def test_onset_threshold_outside_grid():
    below = onset_threshold([2.6, 2.8], [6, 6], [6, 6])
    assert below["threshold"] is None and below["threshold_position"] == "below_grid"
    assert below["lo"] is None and below["hi"] == pytest.approx(2.6)
    above = onset_threshold([2.6, 2.8], [0, 1], [6, 6])
    assert above["threshold"] is None and above["threshold_position"] == "above_grid"
    assert above["hi"] is None
    with pytest.raises(ValueError):
        onset_threshold([2.6], [7], [6])


# ------------------------------------------------------------------ results before compute

@pytest.mark.parametrize("obj,attr", [(BigDiskHeight(), "waiting_time_s"), (BigDiskHeight(), "height"),
                                      (ConvectiveFlux(), "phi"), (ConvectiveFlux(), "depth"),
                                      (VelocityField(), "velocity"), (ForceRatio(), "ratio"),
                                      (ForceRatio(), "mean_with")])
def test_results_before_compute_raise(obj, attr):
    with pytest.raises(RuntimeError, match="compute"):
        getattr(obj, attr)
    with pytest.raises(RuntimeError):
        obj.as_dict()


def test_node_frames_and_settled_frame(tmp_path):
    """Frames: t=0, settle, nodes 1..4, and a final frame off the node; the final
    frame is not a node frame, and a frame just after node 4 does not duplicate it."""
    times = np.r_[node_times(4), SETTLE + 4.02 / FREQ, SETTLE + 4.3 / FREQ]
    path = write_box_run(tmp_path / "nodes.h5", times, np.zeros((times.size, 2, 2)), 0, 1.0)
    run = read_run(path)
    idx, cyc = node_frames(run)
    assert list(cyc) == [1, 2, 3, 4] and list(idx) == [2, 3, 4, 5]
    assert settled_frame(run) == 1


# ------------------------------------------------------------------ real native run

def _small_box_run(tmp_path_factory, name, duration, *extra_sets):
    """A 200-grain, 30 cm box from scenes/box/f3.0_big.toml: 1 s settling, then `duration` s of shaking."""
    if not GRANULAR.exists():
        pytest.skip("build/granular is missing")
    out = tmp_path_factory.mktemp(name) / f"{name}.h5"
    sets = [f"run.duration={duration}", "run.settle=1", "particles.count=200", "box.width=30", *extra_sets]
    subprocess.run([str(GRANULAR), "run", str(REPO_ROOT / "scenes/box/f3.0_big.toml"),
                    *[a for kv in sets for a in ("--set", kv)], "-o", str(out), "--threads", "1", "-q"],
                   check=True, cwd=REPO_ROOT, capture_output=True, timeout=120)
    return read_run(out)


@pytest.fixture(scope="module")
def native_run(tmp_path_factory):
    return _small_box_run(tmp_path_factory, "box", 3)


def _all_finite_numbers(x):
    if isinstance(x, dict):
        return all(_all_finite_numbers(v) for v in x.values())
    if isinstance(x, list):
        return all(_all_finite_numbers(v) for v in x)
    if isinstance(x, float):
        return math.isfinite(x)
    return True


def test_native_run(native_run):
    run = native_run
    assert run.attrs["scene_kind"] == "shaken_box"
    idx, cyc = node_frames(run)
    assert list(cyc) == list(range(1, 10))  # 3 s at 3 Hz
    tr = read_trace(run)
    np.testing.assert_allclose(Shaker(run).y(tr["time"]), tr["box_y"], atol=1e-9)  # same motion as the engine
    np.testing.assert_allclose(Shaker(run).y(run.frames.time[idx]), 0.0, atol=0.01)
    assert read_forces(run).shape == run.frames.position.shape
    H = bed_height(run)
    assert 10.0 < H < 40.0

    d = observe_box(run)
    json.dumps(d)
    assert _all_finite_numbers(d)
    b = d["big_disk_height"]
    assert abs(b["start_height"]) < 0.5           # starts at the floor
    assert b["reached_top"] is False               # 3 s is far too short to rise
    assert math.isfinite(d["convective_flux"]["phi_max"]) and d["convective_flux"]["pairs_used"] == 4
    assert d["velocity_field"]["periods_used"] == 4
    assert d["force_ratio"]["mean_with"] > 0 and d["force_ratio"]["ratio"] is None
    BigDiskHeight().compute(run).plot()
    ConvectiveFlux().compute(run).plot()
    VelocityField().compute(run).plot()


@pytest.fixture(scope="module")
def native_smooth_run(tmp_path_factory):
    return _small_box_run(tmp_path_factory, "box_smooth", 2, "box.walls=smooth")


def test_native_run_smooth_walls(native_smooth_run):
    """box.walls = "smooth": no wall particles in the frames, every grain inside
    the flat walls' surfaces (floor y = y_box, sides x = +-W/2) to within a
    contact's overlap (up to ~0.1 cm here, as against walls of particles; a wall
    a wall-particle radius out of place lets grains 1 cm past it), and the box
    observables as with walls of particles."""
    run = native_smooth_run
    assert run.scene["box"]["walls"] == "smooth"
    fr = run.frames
    assert not np.any(fr.species == 2)
    assert fr.n_frames >= 7  # the settled frame and one per cycle
    half, r = 0.5 * 30.0, 0.5 * fr.diameter
    y_box = Shaker(run).y(fr.time)[:, None]
    assert np.all(np.abs(fr.position[..., 0]) + r <= half + 0.2)
    assert np.all(fr.position[..., 1] - r - y_box >= -0.2)
    tr = read_trace(run)
    np.testing.assert_allclose(Shaker(run).y(tr["time"]), tr["box_y"], atol=1e-9)
    assert 10.0 < bed_height(run) < 40.0
    d = observe_box(run)
    assert _all_finite_numbers(d)
    assert abs(d["big_disk_height"]["start_height"]) < 0.5  # the big disk starts on the floor


def test_onset_command_on_real_runs(tmp_path):
    """compare onset over runs: grouping by frequency, a disk that does not
    reach the top counts as not risen."""
    import sys
    if not GRANULAR.exists():
        pytest.skip("build/granular not built")
    out = tmp_path / "a.h5"
    subprocess.run([str(GRANULAR), "run", str(REPO_ROOT / "scenes/box/f3.0_big.toml"), "--set", "run.duration=1",
                    "--set", "run.settle=0.5", "--set", "particles.count=100", "--set", "box.width=24",
                    "-o", str(out), "--threads", "1", "-q"], check=True, capture_output=True, timeout=300)
    r = subprocess.run([sys.executable, "-m", "compare", "onset", str(out)], capture_output=True, text=True,
                       cwd=REPO_ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)
    assert res["freqs"] == [3.0] and res["trials"] == [1] and res["successes"] == [0]
    assert res["threshold_position"] == "above_grid"


def test_top_motion_on_a_known_oscillation():
    """A disk that reaches the top at 10 s and then moves as top - 10 (1 - cos(2 pi t / 8)) / 2
    dips 10 cm (90th percentile just under it) with a period of 8 s and a
    regularity near 1; white noise instead gives a regularity near 0."""
    from types import SimpleNamespace
    from compare.box import top_motion
    t = np.arange(0.0, 100.0, 0.05)
    top = 50.0
    h = np.where(t < 10, 5 * t, top - 10 * (1 - np.cos(2 * np.pi * (t - 10) / 8)) / 2)
    hd = SimpleNamespace(reached_top=True, times_s=t, height_smoothed=h, top_crossing_s=10.0, top_height=top,
                         start_height=0.0)
    m = top_motion(hd)
    assert 9.0 < m["dip_depth"] <= 10.0 and m["dip_fraction"] == pytest.approx(m["dip_depth"] / 50)
    assert m["period_s"] == pytest.approx(8.0, abs=0.2) and m["regularity"] > 0.8
    rng = np.random.default_rng(3)
    noisy = SimpleNamespace(**dict(vars(hd), height_smoothed=np.where(t < 10, h, top - 10 * rng.random(t.size))))
    assert top_motion(noisy)["regularity"] < 0.2
    assert top_motion(SimpleNamespace(**dict(vars(hd), reached_top=False))) is None


def test_ramp_groups_hysteresis():
    """Onsets up 2.70 +- 0.01 and down 2.64 +- 0.01 over four packings each:
    hysteresis +0.06 Hz with an interval excluding zero; equal onsets give an
    interval containing it."""
    from compare.box_report import ramp_groups
    up = [2.69, 2.70, 2.71, 2.70]
    down = [2.63, 2.64, 2.65, 2.64]
    rows = [{"f_start": 2.4, "f_end": 3.4, "ramp_time": 200.0, "big_disk": False, "onset": f} for f in up] + \
           [{"f_start": 3.4, "f_end": 2.4, "ramp_time": 200.0, "big_disk": False, "onset": f} for f in down]
    g = ramp_groups(rows)[0]
    assert g["rate_hz_per_s"] == pytest.approx(0.005) and g["hysteresis"] == pytest.approx(0.06)
    assert g["hysteresis_ci95"][0] > 0
    same = ramp_groups([dict(r, onset=2.7 + 0.01 * (i % 3)) for i, r in enumerate(rows)])[0]
    assert same["hysteresis_ci95"][0] < 0 < same["hysteresis_ci95"][1]
    # the verdict against the paper's 0.05 Hz: 0.06 apart is different, the same onsets equivalent,
    # and onsets too scattered to bound within 0.05 inconclusive
    assert g["hysteresis_verdict"] == "different" and same["hysteresis_verdict"] == "equivalent"
    wide = ramp_groups([dict(r, onset=2.7 + 0.08 * ((i % 4) - 1.5)) for i, r in enumerate(rows)])[0]
    assert wide["hysteresis_verdict"] == "inconclusive" and wide["hysteresis_ci90"][1] > 0.05


def test_placement_and_forces_commands_refuse_missing_files():
    """`compare box-placement` and `compare box-forces` name the missing file
    in one line and exit 2, like every other subcommand."""
    for args in (["box-placement", "/nonexistent/run.h5"],
                 ["box-forces", "--big", "/nonexistent/a.h5", "--nobig", "/nonexistent/b.h5"]):
        r = subprocess.run(["/usr/bin/python3", "-m", "compare", *args], capture_output=True, text=True,
                           cwd=Path(__file__).resolve().parents[2])
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "nonexistent" in r.stderr


def test_convecting_and_the_mean_interval(tmp_path):
    """compare box-forces splits packings by convection: a depth-mean flux of
    at least 3 particles a cycle over the second half of the run."""
    from compare.box_report import _mean_interval, convecting
    assert convecting(read_run(conveyor_run(tmp_path / "c.h5", 2, 2, cycles=10)))  # Phi = 4
    assert not convecting(read_run(conveyor_run(tmp_path / "w.h5", 1, 1, cycles=10)))  # Phi = 2
    assert not convecting(read_run(conveyor_run(tmp_path / "s.h5", 2, 2, cycles=10, direction=0)))
    # mean 1.1, s.e. 0.1 / sqrt(3), t(0.975, 2) = 4.303
    assert _mean_interval([1.0, 1.2, 1.1]) == "1.100 [0.852, 1.348]"
    assert _mean_interval([]) == "–" and _mean_interval([1.25]) == "1.250"


def test_force_readings_table(tmp_path):
    """compare box-forces: every reading of the measure, then the paper's
    reading split by convection, for a pair of known runs (ratio 1.25)."""
    from compare.box_report import force_readings
    big, ref = force_runs(tmp_path)
    text = force_readings([big.path], [ref.path])
    rows = [l for l in text.splitlines() if l.startswith("| 2 |") or l.startswith("| 2.")]
    assert any("| contact | phase 0 | whole | 1.250 ± nan |" in l for l in rows)
    assert "| not convecting | 1 | 1.250 |" in text and "| convecting | 0 | – |" in text
