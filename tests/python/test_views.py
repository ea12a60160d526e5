"""Drum views (compare/views.py): projection, painting order, depth shading,
circle sizes in data units, the figure's panels and the `views` command."""
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from compare.reader import read_run
from compare.schema_writer import SchemaWriter
from compare.views import FAR_SHADE, drum_views, render_view

REPO_ROOT = Path(__file__).resolve().parents[2]

GREY = (0.8, 0.8, 0.8)


def _widths(coll):
    """Full widths (diameters) of an EllipseCollection's ellipses, in its units."""
    if hasattr(coll, "get_widths"):
        return np.asarray(coll.get_widths())
    return 2 * np.asarray(coll._widths)  # matplotlib < 3.8 keeps the half-widths


def _stacked_pair():
    """Two spheres above one another: the lower one (d = 1) at z = -1, the upper (d = 1.3) at z = +1."""
    pos = np.array([[2.0, 5.0, -1.0], [2.0, 5.0, 1.0]])
    return pos, np.array([1.0, 1.3])


@pytest.mark.parametrize("view, nearest", [("top", 1), ("bottom", 0)])
def test_nearest_sphere_is_painted_last_and_brightest(view, nearest):
    pos, d = _stacked_pair()
    ax = Figure().add_subplot()
    coll = render_view(ax, pos, d, [GREY, GREY], view)
    assert list(coll.order) == [1 - nearest, nearest]
    np.testing.assert_allclose(_widths(coll), [d[1 - nearest], d[nearest]])
    faces = coll.get_facecolor()
    np.testing.assert_allclose(faces[-1, :3], GREY)                # nearest: full colour
    np.testing.assert_allclose(faces[0, :3], np.multiply(GREY, FAR_SHADE))  # farthest: darkest
    assert faces[-1, :3].sum() > faces[0, :3].sum()


def test_top_view_places_circle_of_true_diameter_at_y_x():
    pos = np.array([[3.0, 6.0, 0.5], [-1.0, -2.0, 0.0]])
    d = np.array([2.0, 0.7])
    ax = Figure().add_subplot()
    coll = render_view(ax, pos, d, [GREY, GREY], "top")
    drawn = coll.order
    np.testing.assert_allclose(coll.get_offsets(), pos[drawn][:, [1, 0]])
    np.testing.assert_allclose(_widths(coll), d[drawn])
    assert ax.get_aspect() == 1.0


def test_circle_diameter_in_pixels():
    """Rasterised: a sphere of diameter 2 spans 2 data units on the image."""
    fig = Figure(figsize=(5, 5), dpi=100)  # 500 px for 10 data units: 50 px per unit
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_axis_off()
    render_view(ax, [[3.0, 6.0, 0.0]], [2.0], [(0.0, 0.0, 0.0)], "top")
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 10)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    img = np.asarray(canvas.buffer_rgba())[:, :, 0] < 128  # dark pixels, row 0 at the top
    rows, cols = np.nonzero(img)
    assert abs((cols.max() - cols.min() + 1) - 100) <= 2            # width: 2 units
    assert abs((rows.max() - rows.min() + 1) - 100) <= 2            # height: 2 units
    assert abs((cols.mean() + 0.5) / 50 - 6.0) < 0.05               # centre at image u = y = 6
    assert abs(10 - (rows.mean() + 0.5) / 50 - 3.0) < 0.05          # and at v = x = 3


def test_oblique_view_rotates_about_the_axis():
    pos = np.array([[0.0, 4.0, 1.0]])
    ax = Figure().add_subplot()
    coll = render_view(ax, pos, [1.0], [GREY], "oblique")
    u, v = coll.get_offsets()[0]
    assert u == pytest.approx(4.0)                                  # the axis stays horizontal
    assert v == pytest.approx(math.sin(math.radians(35.0)))


def _write_run(path, n_frames=2):
    rng = np.random.default_rng(3)
    n = 20
    species = np.arange(n) % 2
    diameter = np.where(species == 1, 1.3, 1.0)
    omega = 0.5
    scene = {"scene": {"kind": "drum", "name": "tiny"},
             "drum": {"length": 16.0, "diameter": 8.0, "ends": "walls", "omega": omega}}
    attrs = {"engine": "synthetic", "engine_version": "0", "scene_kind": "drum", "scene_name": "tiny",
             "scene_json": json.dumps(scene), "omega": omega, "rotation_period": 2 * math.pi / omega}
    w = SchemaWriter(path, 3, n, attrs, ["small", "big"])
    for f in range(n_frames):
        pos = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-7, 7, n), rng.uniform(-3, 0, n)])
        w.frame(f * 2 * math.pi / omega, f, np.arange(n), species, diameter, pos, np.zeros((n, 3)),
                np.zeros((n, 3)))
    w.close()
    return path


@pytest.mark.parametrize("views, species_panels, expected", [
    (("top", "bottom"), True, 4), (("top", "bottom", "oblique"), True, 5), (("oblique",), False, 1)])
def test_figure_panels(tmp_path, views, species_panels, expected):
    run = read_run(_write_run(tmp_path / "tiny.h5"))
    fig = drum_views(run, views=views, species_panels=species_panels)
    axes = fig.get_axes()
    assert len(axes) == expected
    assert "tiny" in axes[0].get_title() and "1.0 rotations" in axes[0].get_title()
    if species_panels:
        assert "small only" in axes[-2].get_title() and "big only" in axes[-1].get_title()
        assert len(axes[-1].collections[0].get_offsets()) == 10


def test_bad_frame_and_view(tmp_path):
    run = read_run(_write_run(tmp_path / "tiny.h5"))
    with pytest.raises(ValueError, match="out of range"):
        drum_views(run, frame=5)
    with pytest.raises(ValueError, match="unknown view"):
        drum_views(run, views=("side",))


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "compare", "views", *map(str, args)], cwd=REPO_ROOT,
                          capture_output=True, text=True, timeout=120)


def test_cli_writes_png(tmp_path):
    run = _write_run(tmp_path / "tiny.h5")
    out = tmp_path / "views.png"
    res = _cli(run, "-o", out, "--frame", "0", "--view", "top,oblique")
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == str(out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("make", ["missing", "not_hdf5"])
def test_cli_error_is_one_line(tmp_path, make):
    path = tmp_path / "run.h5"
    if make == "not_hdf5":
        path.write_text("not a run")
    res = _cli(path, "-o", tmp_path / "views.png")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("views: error:") and str(path) in lines[0]
    assert not (tmp_path / "views.png").exists()
