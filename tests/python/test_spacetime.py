"""Tests for compare.reader and compare.spacetime on synthetic granular-frames files."""

import json
import math
import subprocess
from pathlib import Path

import h5py
import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from compare import SpaceTime, axial_profile, read_run  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[2]
PYTHON = "/usr/bin/python3"
OMEGA = 0.5
LENGTH = 8.0
BIG = 1.3


def write_run(path, positions, species, diameter, times=None, ids=None,
              profile=None, drop=(), attrs=None):
    """Write a drum run in the granular-frames schema.

    positions: (F, N, 3); species, diameter: (N,) or (F, N); ids: (F, N) column
    order as written (default sorted); profile: (time, edges, small_fraction) or None.
    drop: names of root attributes or 'frames/<dataset>' to leave out.
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, np.shape(positions)[-2], 3)
    F, N, _ = positions.shape
    species = np.broadcast_to(species, (F, N)).astype(np.int32)
    diameter = np.broadcast_to(diameter, (F, N)).astype(np.float64)
    ids = np.broadcast_to(np.arange(N), (F, N)) if ids is None else np.asarray(ids)
    times = np.arange(F) * 1.0 if times is None else np.asarray(times, dtype=np.float64)
    scene = {"drum": {"length": LENGTH, "diameter": 16.0, "ends": "periodic", "omega": OMEGA},
             "particles": {"small": 1.0, "big": BIG}, "run": {"rotations": 60.0}}
    root = {"schema": "granular-frames", "schema_version": 1, "engine": "test-engine",
            "engine_version": "0.0", "scene_kind": "drum", "scene_name": "A", "dim": 3,
            "scene_json": json.dumps(scene), "omega": OMEGA,
            "rotation_period": 2 * math.pi / OMEGA}
    root.update(attrs or {})
    with h5py.File(path, "w") as h5:
        for k, v in root.items():
            if k not in drop:
                h5.attrs[k] = v
        g = h5.create_group("frames")
        g.attrs["species_names"] = ["small", "big"]
        data = {"time": times, "step": (times * 1000).astype(np.int64), "id": ids.astype(np.int64),
                "species": species, "diameter": diameter, "position": positions,
                "velocity": positions * 2.0, "angular_velocity": positions * 3.0}
        for k, v in data.items():
            if f"frames/{k}" not in drop:
                g.create_dataset(k, data=v)
        if profile is not None:
            p = h5.create_group("profile")
            p.attrs["axis"] = "y"
            p.attrs["weighting"] = "volume"
            for k, v in zip(("time", "edges", "small_fraction"), profile):
                p.create_dataset(k, data=np.asarray(v, dtype=np.float64))
    return path


def segregated_positions(n_frames=3, n_per_half=40, seed=1):
    """Small particles in y<0, big in y>0, random x, z inside the drum."""
    rng = np.random.default_rng(seed)
    n = 2 * n_per_half
    pos = rng.uniform(-5, 5, size=(n_frames, n, 3))
    pos[:, :n_per_half, 1] = rng.uniform(-LENGTH / 2, -0.01, size=(n_frames, n_per_half))
    pos[:, n_per_half:, 1] = rng.uniform(0.01, LENGTH / 2, size=(n_frames, n_per_half))
    species = np.r_[np.zeros(n_per_half), np.ones(n_per_half)]
    diameter = np.where(species == 0, 1.0, BIG)
    return pos, species, diameter


@pytest.fixture(autouse=True)
def _close_figures():
    """SpaceTime.plot() without an axis opens pyplot figures; don't let them pile up."""
    yield
    import matplotlib.pyplot as plt
    plt.close("all")


# (a) the profile itself -------------------------------------------------------

def test_axial_profile_is_volume_weighted_and_nan_when_empty():
    edges = [0.0, 1.0, 2.0, 3.0, 4.0]
    y = [0.5, 0.7,            # slice 0: one small d=1, one big d=1.3
         1.2, 1.4, 1.9,       # slice 1: two small d=1, one big d=1.3
         3.5,                 # slice 3: big only; slice 2 empty
         -0.5, 4.5]           # outside: ignored
    species = [0, 1, 0, 0, 1, 1, 0, 0]
    diameter = [1.0, BIG, 1.0, 1.0, BIG, BIG, 1.0, 1.0]
    frac = axial_profile(y, diameter, species, edges)
    assert frac.shape == (4,)
    assert frac[0] == pytest.approx(1.0 / (1.0 + BIG ** 3), rel=1e-14)
    assert frac[1] == pytest.approx(2.0 / (2.0 + BIG ** 3), rel=1e-14)
    assert frac[1] != pytest.approx(2.0 / 3.0)  # not a number fraction
    assert np.isnan(frac[2])
    assert frac[3] == 0.0


def test_axial_profile_small_diameters_weighted_too():
    # two small particles of different size: still pure small -> 1
    frac = axial_profile([0.1, 0.2, 0.3], [1.0, 0.8, 2.0], [0, 0, 1], [0.0, 1.0])
    assert frac[0] == pytest.approx((1 + 0.8 ** 3) / (1 + 0.8 ** 3 + 8.0))


# (b) segregated frames ---------------------------------------------------------

def test_segregated_frames_give_one_below_zero_below_and_zero_above(tmp_path):
    pos, species, diameter = segregated_positions()
    run = read_run(write_run(tmp_path / "seg.h5", pos, species, diameter))
    st = SpaceTime().compute(run)
    assert st.source == "frames"
    assert st.small_fraction.shape == (3, 8)
    np.testing.assert_allclose(st.y_centres, np.arange(-3.5, 4.0, 1.0))
    lower = st.y_centres < 0
    np.testing.assert_array_equal(st.small_fraction[:, lower], 1.0)
    np.testing.assert_array_equal(st.small_fraction[:, ~lower], 0.0)
    np.testing.assert_allclose(st.time_rotations, np.arange(3) * OMEGA / (2 * math.pi))


def test_slice_width_sets_number_of_slices(tmp_path):
    pos, species, diameter = segregated_positions()
    run = read_run(write_run(tmp_path / "seg.h5", pos, species, diameter))
    st = SpaceTime(slice_width=2.0).compute(run)
    assert st.small_fraction.shape == (3, 4)
    np.testing.assert_allclose(st.y_edges, [-4, -2, 0, 2, 4])


def test_unwrapped_periodic_coordinates_are_wrapped(tmp_path):
    pos, species, diameter = segregated_positions()
    shifted = pos.copy()
    shifted[..., 1] += 3 * LENGTH  # same state, unwrapped by three periods
    a = SpaceTime().compute(read_run(write_run(tmp_path / "a.h5", pos, species, diameter)))
    b = SpaceTime().compute(read_run(write_run(tmp_path / "b.h5", shifted, species, diameter)))
    np.testing.assert_allclose(b.small_fraction, a.small_fraction)


# (c) profile source -------------------------------------------------------------

def test_frames_used_when_profile_absent_and_match_direct_calculation(tmp_path):
    rng = np.random.default_rng(7)
    pos = rng.uniform(-LENGTH / 2, LENGTH / 2, size=(4, 60, 3))
    species = rng.integers(0, 2, size=60)
    diameter = np.where(species == 0, 1.0, BIG)
    run = read_run(write_run(tmp_path / "mix.h5", pos, species, diameter))
    st = SpaceTime().compute(run)
    assert st.source == "frames"
    edges = np.linspace(-LENGTH / 2, LENGTH / 2, 9)
    expected = np.array([axial_profile(pos[f, :, 1], diameter, species, edges) for f in range(4)])
    np.testing.assert_allclose(st.small_fraction, expected)
    assert 0 < np.nanmin(st.small_fraction) and np.nanmax(st.small_fraction) < 1  # really mixed


def test_profile_used_as_is_when_present(tmp_path):
    pos, species, diameter = segregated_positions()
    ptime = np.linspace(0.0, 50.0, 11)
    pedges = np.linspace(-LENGTH / 2, LENGTH / 2, 17)
    pfrac = np.random.default_rng(3).uniform(size=(11, 16))
    pfrac[2, 5] = np.nan
    run = read_run(write_run(tmp_path / "p.h5", pos, species, diameter,
                             profile=(ptime, pedges, pfrac)))
    st = SpaceTime(slice_width=1.0).compute(run)
    assert st.source == "profile"
    np.testing.assert_array_equal(st.small_fraction, pfrac)  # NaN included
    np.testing.assert_array_equal(st.y_edges, pedges)
    np.testing.assert_allclose(st.time_rotations, ptime / (2 * math.pi / OMEGA))


def test_empty_profile_falls_back_to_frames(tmp_path):
    pos, species, diameter = segregated_positions()
    empty = (np.zeros(0), np.linspace(-4, 4, 17), np.zeros((0, 16)))
    run = read_run(write_run(tmp_path / "e.h5", pos, species, diameter, profile=empty))
    st = SpaceTime().compute(run)
    assert st.source == "frames"
    assert st.small_fraction.shape == (3, 8)


def test_zero_frames_and_zero_profile_rows_do_not_crash(tmp_path):
    empty = (np.zeros(0), np.linspace(-4, 4, 17), np.zeros((0, 16)))
    path = write_run(tmp_path / "z.h5", np.zeros((0, 5, 3)), np.zeros(5), np.ones(5),
                     times=np.zeros(0), ids=np.zeros((0, 5)), profile=empty)
    run = read_run(path)
    assert run.frames.n_frames == 0 and run.frames.position.shape == (0, 5, 3)
    st = SpaceTime().compute(run)
    assert st.small_fraction.shape == (0, 8) and st.time_rotations.shape == (0,)
    st.plot()


def test_plot_labels_and_colour_scale(tmp_path):
    pos, species, diameter = segregated_positions()
    st = SpaceTime().compute(read_run(write_run(tmp_path / "seg.h5", pos, species, diameter)))
    ax = st.plot()
    assert ax.get_xlabel() == "rotations"
    assert ax.get_ylabel() == "axial position y"
    mesh = ax.collections[0]
    assert mesh.cmap.name.startswith("gray_r")
    assert (mesh.norm.vmin, mesh.norm.vmax) == (0.0, 1.0)
    # dark = small: fraction 1 maps to black
    assert mesh.cmap(mesh.norm(1.0))[:3] == pytest.approx((0.0, 0.0, 0.0))
    cbar_ax = [a for a in ax.figure.axes if a is not ax][0]
    assert "small-particle volume fraction" in (cbar_ax.get_ylabel() + cbar_ax.get_xlabel())


# (d) results before compute --------------------------------------------------------

@pytest.mark.parametrize("name", ["time_rotations", "y_centres", "small_fraction"])
def test_results_before_compute_raise(name):
    with pytest.raises(RuntimeError, match="compute"):
        getattr(SpaceTime(), name)


# (e) re-ordering by id ---------------------------------------------------------------

def test_reader_reorders_particles_by_id(tmp_path):
    rng = np.random.default_rng(11)
    F, N = 4, 12
    ids = np.array([rng.permutation(N) + 100 for _ in range(F)])
    # every per-particle quantity encodes (id, frame) so a mismatch is visible
    pos = np.zeros((F, N, 3))
    pos[..., 0] = ids
    pos[..., 1] = np.arange(F)[:, None]
    species = (ids % 2).astype(np.int32)
    diameter = 1.0 + ids / 1000.0
    run = read_run(write_run(tmp_path / "perm.h5", pos, species, diameter, ids=ids))
    fr = run.frames
    expected_ids = np.broadcast_to(np.arange(N) + 100, (F, N))
    np.testing.assert_array_equal(fr.id, expected_ids)
    np.testing.assert_array_equal(fr.position[..., 0], expected_ids)
    np.testing.assert_array_equal(fr.position[..., 1], np.broadcast_to(np.arange(F)[:, None], (F, N)))
    np.testing.assert_array_equal(fr.velocity, 2.0 * fr.position)
    np.testing.assert_array_equal(fr.angular_velocity, 3.0 * fr.position)
    np.testing.assert_array_equal(fr.species, expected_ids % 2)
    np.testing.assert_allclose(fr.diameter, 1.0 + expected_ids / 1000.0)
    assert fr.position.dtype == np.float64 and fr.time.dtype == np.float64


def test_reader_attrs_scene_and_rotation_period(tmp_path):
    pos, species, diameter = segregated_positions()
    path = write_run(tmp_path / "seg.h5", pos, species, diameter,
                     attrs={"engine": np.bytes_(b"fixed-length-engine")},
                     drop=("rotation_period",))
    run = read_run(path)
    assert run.attrs["engine"] == "fixed-length-engine"  # bytes decoded
    assert run.attrs["scene_name"] == "A"
    assert run.scene["drum"]["length"] == LENGTH
    assert run.dim == 3
    assert run.rotation_period == pytest.approx(2 * math.pi / OMEGA)  # derived from omega
    assert run.frames.species_names == ("small", "big")
    assert run.profile is None


# (f) schema errors ------------------------------------------------------------------------

@pytest.mark.parametrize("drop, attrs, match", [
    (("schema",), None, "schema"),
    ((), {"schema": "something-else"}, "schema"),
    ((), {"schema_version": 2}, "schema_version"),
    (("frames/velocity",), None, "velocity"),
])
def test_not_this_schema_raises_valueerror_naming_file(tmp_path, drop, attrs, match):
    pos, species, diameter = segregated_positions()
    path = write_run(tmp_path / "bad_file.h5", pos, species, diameter, drop=drop, attrs=attrs)
    with pytest.raises(ValueError, match=match) as info:
        read_run(path)
    assert "bad_file.h5" in str(info.value)


def test_non_hdf5_file_raises_valueerror(tmp_path):
    path = tmp_path / "notes.h5"
    path.write_text("not hdf5")
    with pytest.raises(ValueError, match="notes.h5"):
        read_run(path)


# (g) CLI ----------------------------------------------------------------------------------

def run_cli(*args):
    return subprocess.run([PYTHON, "-m", "compare", *map(str, args)], cwd=REPO_ROOT,
                          capture_output=True, text=True, timeout=120)


def test_quicklook_cli_writes_png(tmp_path):
    pos, species, diameter = segregated_positions()
    h5 = write_run(tmp_path / "seg.h5", pos, species, diameter)
    png = tmp_path / "plot.png"
    res = run_cli("quicklook", h5, "-o", png)
    assert res.returncode == 0, res.stderr
    assert png.stat().st_size > 1000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert res.stdout.strip().splitlines() == [str(png)]


def test_quicklook_cli_missing_file_exits_2(tmp_path):
    missing = tmp_path / "does_not_exist.h5"
    res = run_cli("quicklook", missing, "-o", tmp_path / "x.png")
    assert res.returncode == 2
    assert "does_not_exist.h5" in res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "x.png").exists()


def test_quicklook_cli_wrong_schema_exits_2(tmp_path):
    pos, species, diameter = segregated_positions()
    h5 = write_run(tmp_path / "noschema.h5", pos, species, diameter, drop=("schema",))
    res = run_cli("quicklook", h5, "-o", tmp_path / "x.png")
    assert res.returncode == 2
    assert "noschema.h5" in res.stderr and "schema" in res.stderr
    assert "Traceback" not in res.stderr
