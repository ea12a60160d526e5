"""Tests for compare.surface.FreeSurface on synthetic granular-frames files.

The synthetic beds are jittered lattices (spacing 1) of spheres inside the
drum's circle r < D/2 - 0.5, stacked downwards from a plane z = tan(theta) x + c
so that the top of each column's highest sphere lies on the plane (plus a small
jitter): the surface heights are then known exactly, and any error in the cell
assignment, surface-particle choice, averaging, extent or fit shows up.
"""

import json
import math

import h5py
import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from compare.reader import read_run  # noqa: E402
from compare.surface import FreeSurface  # noqa: E402

OMEGA = 0.5
PERIOD = 2 * math.pi / OMEGA
D = 16.0
L = 32.0
SMALL_D = (0.8, 1.0)
BIG_D = (1.1, 1.3)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt
    plt.close("all")


# -- synthetic data -----------------------------------------------------------------

def bed(theta_deg, c=-1.0, seed=0, top_species=None, jitter=0.15):
    """Spheres filling the drum below the plane z = tan(theta) x + c.

    Lattice columns at x, y = k + 0.5 (jittered by +-jitter); in each column the
    spheres are stacked downwards with spacing 1, the first one touching the plane
    from below, keeping those whose centre is inside r < D/2 - 0.5.
    top_species(x) -> 0/1 sets the species of each column's top sphere (default:
    random, like the rest).  Returns position (N, 3), species (N,), diameter (N,).
    """
    rng = np.random.default_rng(seed)
    slope = math.tan(math.radians(theta_deg))
    r_max = D / 2 - 0.5
    pos, spec, dia = [], [], []
    for xc in np.arange(-D / 2 + 0.5, D / 2, 1.0):
        for yc in np.arange(-L / 2 + 0.5, L / 2, 1.0):
            x = xc + rng.uniform(-jitter, jitter)
            y = yc + rng.uniform(-jitter, jitter)
            plane = slope * x + c
            first = True
            k = 0
            while True:
                s = int(rng.integers(0, 2))
                if first and top_species is not None:
                    s = int(top_species(x))
                d = rng.uniform(*(BIG_D if s else SMALL_D))
                z = plane - d / 2 - k + rng.uniform(-0.05, 0.05)
                k += 1
                if z < -r_max:
                    break
                if x * x + z * z >= r_max ** 2:
                    continue  # above the wall: try one lattice step lower
                pos.append((x, y, z))
                spec.append(s)
                dia.append(d)
                first = False
    return np.array(pos), np.array(spec, dtype=np.int32), np.array(dia)


def pad(frames):
    """Make every frame hold the same number of particles (the schema needs a
    constant set of ids): extra copies of each frame's lowest sphere, a little
    lower still, so they are never a surface particle."""
    n = max((p.shape[0] for p, _, _ in frames), default=0)
    out = []
    for p, s, d in frames:
        extra = n - p.shape[0]
        low = int(np.argmin(p[:, 2]))
        ep = np.repeat(p[low:low + 1], extra, axis=0)
        ep[:, 2] -= 0.01 * (1 + np.arange(extra))
        out.append((np.vstack([p, ep]), np.r_[s, np.full(extra, s[low])],
                    np.r_[d, np.full(extra, d[low])]))
    return out


def write_run(path, frames, times_rot=None, scene_kind="drum", ends="periodic"):
    """Write frames [(position, species, diameter), ...] as a granular-frames file."""
    frames = pad(frames)
    F = len(frames)
    N = frames[0][0].shape[0] if F else 0
    pos = np.array([f[0] for f in frames]).reshape(F, N, 3)
    species = np.array([f[1] for f in frames], dtype=np.int32).reshape(F, N)
    diameter = np.array([f[2] for f in frames]).reshape(F, N)
    times_rot = np.arange(F, dtype=float) if times_rot is None else np.asarray(times_rot, float)
    times = times_rot * PERIOD
    scene = {"drum": {"length": L, "diameter": D, "ends": ends, "omega": OMEGA},
             "particles": {"small": 1.0, "big": 1.2}, "run": {"rotations": 10.0}}
    root = {"schema": "granular-frames", "schema_version": 1, "engine": "test-engine",
            "engine_version": "0.0", "scene_kind": scene_kind, "scene_name": "T", "dim": 3,
            "scene_json": json.dumps(scene), "omega": OMEGA, "rotation_period": PERIOD}
    with h5py.File(path, "w") as h5:
        for k, v in root.items():
            h5.attrs[k] = v
        g = h5.create_group("frames")
        g.attrs["species_names"] = ["small", "big"]
        g.create_dataset("time", data=times)
        g.create_dataset("step", data=(times * 200).astype(np.int64))
        g.create_dataset("id", data=np.broadcast_to(np.arange(N), (F, N)).astype(np.int64))
        g.create_dataset("species", data=species)
        g.create_dataset("diameter", data=diameter)
        g.create_dataset("position", data=pos)
        g.create_dataset("velocity", data=np.zeros_like(pos))
        g.create_dataset("angular_velocity", data=np.zeros_like(pos))
    return read_run(path)


# -- slope angle --------------------------------------------------------------------

@pytest.mark.parametrize("theta", [0.0, 12.0, -12.0, 25.0, -25.0])
def test_slope_angle_of_a_plane_surface(tmp_path, theta):
    run = write_run(tmp_path / "bed.h5", [bed(theta, seed=3)])
    fs = FreeSurface().compute(run)
    assert fs.slope_angle_deg == pytest.approx(abs(theta), abs=0.5)
    if theta == 0:
        assert abs(fs.slope) < math.tan(math.radians(0.5))
    else:
        assert np.sign(fs.slope) == np.sign(theta)
    assert fs.slope == pytest.approx(math.tan(math.radians(theta)), abs=0.01)
    # the fit window is the central half of an extent that stays inside the drum
    lo, hi = fs.fit_range
    e_lo, e_hi = fs.extent
    assert -D / 2 <= e_lo < lo < hi < e_hi <= D / 2
    assert hi - lo == pytest.approx(0.5 * (e_hi - e_lo))
    assert 0.5 * (lo + hi) == pytest.approx(0.5 * (e_lo + e_hi))


def test_heights_follow_the_plane_inside_the_fit_window(tmp_path):
    theta, c = 20.0, -1.0
    run = write_run(tmp_path / "bed.h5", [bed(theta, c=c, seed=5)])
    fs = FreeSurface().compute(run)
    np.testing.assert_allclose(fs.x, np.arange(-7.5, 8.0, 1.0))
    lo, hi = fs.fit_range
    win = (fs.x >= lo) & (fs.x <= hi)
    assert win.sum() >= 5
    expected = c + math.tan(math.radians(theta)) * fs.x[win]
    np.testing.assert_allclose(fs.height[win], expected, atol=0.05)
    assert fs.intercept == pytest.approx(c, abs=0.05)
    # every y-cell of a window column holds particles: 32 cells per column, one frame
    np.testing.assert_array_equal(fs.counts[win], int(L))


def test_columns_reaching_the_wall_are_excluded_from_the_extent(tmp_path):
    # flat bed at z = -2, but on the right the bed climbs the wall (the end of the
    # S-shaped profile): in the columns x = 5.5 and 6.5 a sphere sits with its top
    # 0.2 below the wall arc.  Those columns (and the column beyond them) must be
    # outside the extent, so even a fit over the whole extent stays flat.
    pos, species, diameter = bed(0.0, c=-2.0, seed=2)
    rng = np.random.default_rng(9)
    extra = []
    for xc in (5.5, 6.5):
        for yc in np.arange(-L / 2 + 0.5, L / 2, 1.0):
            x = xc + rng.uniform(-0.15, 0.15)
            top = math.sqrt((D / 2) ** 2 - xc ** 2) - 0.2
            extra.append((x, yc, top - 0.5))
    pos = np.vstack([pos, extra])
    species = np.r_[species, np.zeros(len(extra), dtype=np.int32)]
    diameter = np.r_[diameter, np.ones(len(extra))]
    run = write_run(tmp_path / "climb.h5", [(pos, species, diameter)])

    fs = FreeSurface(fit_window=1.0).compute(run)
    wall = np.sqrt((D / 2) ** 2 - fs.x ** 2)
    climb = np.isin(fs.x, [5.5, 6.5])
    np.testing.assert_allclose(fs.height[climb], wall[climb] - 0.2, atol=1e-9)
    lo, hi = fs.extent
    assert hi == pytest.approx(5.0)
    assert lo < -6.0
    inside = (fs.x > lo) & (fs.x < hi)
    assert np.all(fs.height[inside] < wall[inside] - 0.5)
    assert fs.fit_range == pytest.approx(fs.extent)
    assert fs.slope_angle_deg < 0.5
    # the default window is the central half of that extent
    fs = FreeSurface().compute(run)
    mid, width = 0.5 * (lo + hi), hi - lo
    assert fs.fit_range == pytest.approx((mid - width / 4, mid + width / 4))


# -- surface particle and per-species heights --------------------------------------

def test_surface_particle_is_the_highest_top_not_the_highest_centre(tmp_path):
    # one cell (x in [0,1], y in [0,1]): big centre 0.0, d 1.3 -> top 0.65;
    # small centre 0.1, d 0.8 -> top 0.5.  A second cell with a small particle only.
    pos = np.array([[0.5, 0.5, 0.0], [0.5, 0.6, 0.1], [0.5, 1.5, 0.2]])
    species = np.array([1, 0, 0], dtype=np.int32)
    diameter = np.array([1.3, 0.8, 1.0])
    run = write_run(tmp_path / "two.h5", [(pos, species, diameter)])
    fs = FreeSurface().compute(run)
    col = int(np.flatnonzero(np.isclose(fs.x, 0.5))[0])
    assert fs.counts[col] == 2
    assert fs.height[col] == pytest.approx((0.65 + 0.7) / 2)
    assert fs.height_by_species["big"][col] == pytest.approx(0.65)
    assert fs.height_by_species["small"][col] == pytest.approx(0.7)
    assert fs.counts_by_species["big"][col] == 1
    assert fs.counts_by_species["small"][col] == 1
    others = np.arange(fs.x.size) != col
    assert np.all(np.isnan(fs.height[others]))
    assert np.all(fs.counts[others] == 0)


def test_per_species_heights_where_each_species_is_on_top(tmp_path):
    theta = 15.0
    frames = [bed(theta, seed=11, top_species=lambda x: 1 if x < 0 else 0)]
    run = write_run(tmp_path / "sp.h5", frames)
    fs = FreeSurface().compute(run)
    h = fs.height_by_species
    assert set(h) == {"small", "big"}
    filled = fs.counts > 0
    left, right = filled & (fs.x < 0), filled & (fs.x > 0)
    assert left.any() and right.any()
    assert np.all(np.isfinite(h["big"][left])) and np.all(np.isnan(h["big"][right]))
    assert np.all(np.isfinite(h["small"][right])) and np.all(np.isnan(h["small"][left]))
    np.testing.assert_allclose(h["big"][left], fs.height[left])
    np.testing.assert_allclose(h["small"][right], fs.height[right])
    # each half of the window has enough columns for its own fit
    for name in ("small", "big"):
        assert fs.slope_angle_deg_by_species[name] == pytest.approx(theta, abs=0.75)


def test_per_species_angle_is_nan_without_enough_columns(tmp_path):
    # big particles on top only at x > 6: no big column inside the fit window
    frames = [bed(10.0, seed=4, top_species=lambda x: 1 if x > 6 else 0)]
    fs = FreeSurface().compute(write_run(tmp_path / "sp.h5", frames))
    assert math.isnan(fs.slope_angle_deg_by_species["big"])
    assert fs.slope_angle_deg_by_species["small"] == pytest.approx(10.0, abs=0.5)


# -- frames ---------------------------------------------------------------------------

def test_frames_are_averaged(tmp_path):
    # h(x) averages over frames: planes at 10 and 20 deg average to slope
    # (tan 10 + tan 20) / 2; +theta and -theta average to a flat surface
    run = write_run(tmp_path / "two.h5", [bed(10.0, seed=1), bed(20.0, seed=2)])
    fs = FreeSurface(skip_rotations=0).compute(run)
    mean_slope = 0.5 * (math.tan(math.radians(10)) + math.tan(math.radians(20)))
    assert fs.slope == pytest.approx(mean_slope, abs=0.01)
    assert fs.slope_angle_deg == pytest.approx(math.degrees(math.atan(mean_slope)), abs=0.5)
    lo, hi = fs.fit_range
    win = (fs.x >= lo) & (fs.x <= hi)
    np.testing.assert_array_equal(fs.counts[win], 2 * int(L))

    run = write_run(tmp_path / "pm.h5", [bed(15.0, seed=1), bed(-15.0, seed=2)])
    fs = FreeSurface(skip_rotations=0).compute(run)
    assert fs.slope_angle_deg < 0.5


def test_frames_parameter_takes_the_last_frames(tmp_path):
    frames = [bed(40.0, c=-2.0, seed=0), bed(10.0, seed=1), bed(20.0, seed=2)]
    run = write_run(tmp_path / "three.h5", frames, times_rot=[1.0, 2.0, 3.0])
    fs2 = FreeSurface(frames=2, skip_rotations=0).compute(run)
    np.testing.assert_allclose(fs2.frames_used, [2.0, 3.0])
    mean_slope = 0.5 * (math.tan(math.radians(10)) + math.tan(math.radians(20)))
    assert fs2.slope == pytest.approx(mean_slope, abs=0.01)
    fs1 = FreeSurface(frames=1, skip_rotations=0).compute(run)
    np.testing.assert_allclose(fs1.frames_used, [3.0])
    assert fs1.slope_angle_deg == pytest.approx(20.0, abs=0.5)
    fs_all = FreeSurface(skip_rotations=0).compute(run)  # default 10 > 3: all frames
    np.testing.assert_allclose(fs_all.frames_used, [1.0, 2.0, 3.0])
    assert fs_all.slope > fs2.slope + 0.05  # the 40 deg frame pulls it up


def test_min_gap_rotations_spaces_the_frames(tmp_path):
    times = [0.0, 0.5, 1.0, 1.8, 2.0]
    frames = [bed(12.0, seed=i) for i in range(len(times))]
    run = write_run(tmp_path / "five.h5", frames, times_rot=times)
    fs = FreeSurface(min_gap_rotations=1.0, skip_rotations=0).compute(run)
    np.testing.assert_allclose(fs.frames_used, [0.0, 1.0, 2.0])
    fs = FreeSurface(frames=2, min_gap_rotations=1.0, skip_rotations=0).compute(run)
    np.testing.assert_allclose(fs.frames_used, [1.0, 2.0])
    fs = FreeSurface(frames=3, skip_rotations=0).compute(run)
    np.testing.assert_allclose(fs.frames_used, [1.0, 1.8, 2.0])


def test_start_up_snapshots_are_skipped(tmp_path):
    """The initial lattice and the first rotations are not a flowing surface."""
    times = [0.0, 1.0, 2.0, 3.0]
    frames = [bed(40.0, seed=0), bed(40.0, seed=1), bed(12.0, seed=2), bed(12.0, seed=3)]
    run = write_run(tmp_path / "skip.h5", frames, times_rot=times)
    fs = FreeSurface().compute(run)  # default skip_rotations = 2
    np.testing.assert_allclose(fs.frames_used, [2.0, 3.0])
    assert fs.slope_angle_deg == pytest.approx(12.0, abs=0.5)
    only_early = write_run(tmp_path / "early.h5", frames[:2], times_rot=times[:2])
    assert fs.settled
    early = FreeSurface().compute(only_early)
    np.testing.assert_allclose(early.frames_used, [1.0])  # falls back to the last
    assert not early.settled and early.as_dict()["settled"] is False
    assert FreeSurface(skip_rotations=0).compute(only_early).settled


# -- errors, output, plot ------------------------------------------------------------------

def test_results_before_compute_raise_runtime_error():
    fs = FreeSurface()
    for name in ("x", "height", "height_by_species", "counts", "slope", "slope_angle_deg",
                 "slope_angle_deg_by_species", "fit_range", "frames_used"):
        with pytest.raises(RuntimeError, match="compute"):
            getattr(fs, name)
    with pytest.raises(RuntimeError):
        fs.as_dict()
    with pytest.raises(RuntimeError):
        fs.plot()


def test_non_drum_run_and_empty_run_raise_value_error(tmp_path):
    run = write_run(tmp_path / "box.h5", [bed(10.0)], scene_kind="shaken_box")
    with pytest.raises(ValueError, match="drum"):
        FreeSurface().compute(run)
    run = write_run(tmp_path / "empty.h5", [])
    with pytest.raises(ValueError, match="no frames"):
        FreeSurface().compute(run)


@pytest.mark.parametrize("kwargs", [dict(cell=0), dict(frames=0), dict(frames=1.5),
                                    dict(fit_window=0), dict(fit_window=1.5),
                                    dict(min_gap_rotations=-1)])
def test_bad_parameters_raise_value_error(kwargs):
    with pytest.raises(ValueError):
        FreeSurface(**kwargs)


def test_as_dict_is_plain_json(tmp_path):
    run = write_run(tmp_path / "bed.h5", [bed(12.0, seed=3)], times_rot=[5.0])
    fs = FreeSurface().compute(run)
    d = json.loads(json.dumps(fs.as_dict(), allow_nan=False))
    for key in ("slope_angle_deg", "slope", "slope_angle_deg_by_species", "fit_range",
                "frames_used", "x", "height"):
        assert key in d
    assert d["slope_angle_deg"] == pytest.approx(fs.slope_angle_deg)
    assert d["frames_used"] == [5.0]
    assert len(d["x"]) == len(d["height"]) == 16
    empty = np.isnan(fs.height)
    assert empty.any()  # the outermost low-side column is empty
    assert all(v is None for v, e in zip(d["height"], empty) if e)
    assert all(isinstance(v, float) for v, e in zip(d["height"], empty) if not e)
    assert set(d["slope_angle_deg_by_species"]) == {"small", "big"}


def test_plot_draws_species_wall_and_fit(tmp_path):
    import matplotlib.pyplot as plt
    run = write_run(tmp_path / "bed.h5", [bed(12.0, seed=3)])
    fs = FreeSurface().compute(run)
    fig, ax = plt.subplots()
    out = fs.plot(ax)
    assert out is ax
    labels = [line.get_label() for line in ax.lines]
    assert {"small", "big", "wall"} <= set(labels)
    assert any(lab.startswith("fit") for lab in labels)
    small = ax.lines[labels.index("small")]
    big = ax.lines[labels.index("big")]
    assert small.get_marker() == "o" and big.get_marker() == "o"
    assert big.get_markersize() > small.get_markersize()
    assert ax.get_xlabel() == "x (across the drum)"
    assert ax.get_ylabel() == "surface height z"
    assert f"{fs.slope_angle_deg:.1f}" in ax.get_title()
    assert ax.get_aspect() == 1.0
    fig.savefig(tmp_path / "surface.png")
    assert (tmp_path / "surface.png").stat().st_size > 0
    # without an axis: makes its own figure
    assert fs.plot() is not None
