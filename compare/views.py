"""Pictures of the particles in the drum, in the manner of Rapaport (2002):
the bed seen from above, from below, or obliquely, with small and big particles
together or separately.

Each sphere is drawn as a filled circle of its true diameter in data units.
A view is a rotation R of the drum frame followed by an orthographic
projection: with q = R p, the image plane is (q_y, q_x) (the drum's axis y is
always horizontal, since every view rotates about y) and q_z is the height
towards the viewer. Circles are painted far to near, and each colour is scaled
by a depth factor from 0.45 (farthest) to 1 (nearest), so the nearer spheres
look brighter.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.collections import EllipseCollection
from matplotlib.figure import Figure

from .reader import read_run

OBLIQUE_DEG = 35.0
FAR_SHADE, NEAR_SHADE = 0.45, 1.0
SMALL_RGB = (0.25, 0.25, 0.25)   # dark: small particles
BIG_RGB = (0.93, 0.93, 0.90)     # light: big particles
EDGE_RGB = (0.35, 0.35, 0.35)    # thin outline of the big particles
EDGE_WIDTH = 0.3                 # points


def _rot_y(deg):
    """Rotation about the y axis by deg degrees (z turns towards +x for deg > 0)."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


VIEWS = {
    "top": np.eye(3),            # looking down -z; image (y, x)
    "bottom": _rot_y(180.0),     # looking up +z; image (y, -x)
    "oblique": _rot_y(OBLIQUE_DEG),  # viewer above, tilted 35 deg about y towards -x
}
VERTICAL_LABELS = {"top": "x", "bottom": "\u2212x", "oblique": "x rotated"}
VIEW_LABELS = {"top": "from above", "bottom": "from below", "oblique": f"oblique ({OBLIQUE_DEG:g}\u00b0)"}


def project(positions, view):
    """Image coordinates (M, 2) and nearness (M,) (larger = nearer the viewer)."""
    if view not in VIEWS:
        raise ValueError(f"unknown view {view!r}; choose from {', '.join(VIEWS)}")
    q = np.asarray(positions, dtype=float).reshape(-1, 3) @ VIEWS[view].T
    return np.column_stack([q[:, 1], q[:, 0]]), q[:, 2]


def depth_shade(nearness):
    """Colour factor per sphere: FAR_SHADE at the farthest, NEAR_SHADE at the nearest."""
    nearness = np.asarray(nearness, dtype=float)
    if nearness.size == 0:
        return nearness
    span = float(nearness.max() - nearness.min())
    if span <= 0.0:
        return np.full(nearness.shape, NEAR_SHADE)
    return FAR_SHADE + (NEAR_SHADE - FAR_SHADE) * (nearness - nearness.min()) / span


def render_view(ax, positions, diameters, colors, view="top", edgecolors=None, linewidths=0.0):
    """Draw spheres on ax as seen in `view`; return the EllipseCollection.

    positions (M, 3), diameters (M,), colors (M, 3) or (M, 4) RGB(A) in [0, 1]
    (or one colour for all). The collection holds the spheres far to near, so
    its last entry is the nearest; faces and edges are scaled by depth_shade.
    Axis limits are set to the spheres' extent, with equal aspect.
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    d = np.asarray(diameters, dtype=float).reshape(-1)
    m = positions.shape[0]
    if d.shape[0] != m:
        raise ValueError(f"{m} positions but {d.shape[0]} diameters")
    uv, near = project(positions, view)
    order = np.argsort(near, kind="stable")
    shade = depth_shade(near)[order, None]

    def shaded(c):
        c = np.array(np.broadcast_to(np.asarray(c, dtype=float), (m, np.shape(c)[-1])))[order]
        c[:, :3] *= shade
        return c

    lw = np.asarray(linewidths, dtype=float)
    coll = EllipseCollection(d[order], d[order], np.zeros(m), units="xy", offsets=uv[order],
                             offset_transform=ax.transData, facecolors=shaded(colors),
                             edgecolors="none" if edgecolors is None else shaded(edgecolors),
                             linewidths=lw[order] if lw.ndim else lw)
    coll.order = order  # index into the input of each drawn sphere, far to near
    ax.add_collection(coll)
    if m:
        r = d[:, None] / 2
        lo, hi = (uv - r).min(axis=0), (uv + r).max(axis=0)
        pad = 0.02 * float(max(hi - lo))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    return coll


def species_colors(species):
    """Face colour, edge colour and edge width per particle: small dark, big light with an outline."""
    big = np.asarray(species) == 1
    face = np.where(big[:, None], BIG_RGB, SMALL_RGB)
    edge = np.where(big[:, None], EDGE_RGB, SMALL_RGB)
    return face, edge, np.where(big, EDGE_WIDTH, 0.0)


def _drum_outline(ax, drum):
    """The drum's silhouette: the lines x = +-D/2 and, with walls, the end caps."""
    length, radius = float(drum["length"]), float(drum["diameter"]) / 2
    kw = dict(color="0.5", lw=0.6, zorder=0.5)
    ax.plot([-length / 2, length / 2], [radius, radius], **kw)
    ax.plot([-length / 2, length / 2], [-radius, -radius], **kw)
    if drum.get("ends", "periodic") != "periodic":
        for y in (-length / 2, length / 2):
            ax.plot([y, y], [-radius, radius], **kw)
    pad = 0.01 * length
    ax.set_xlim(-length / 2 - pad, length / 2 + pad)
    ax.set_ylim(-radius - pad, radius + pad)


def drum_views(run, frame=-1, views=("top", "bottom"), species_panels=True):
    """A Figure of one frame of a drum run: a row per view with every particle,
    then (species_panels) the top view of the small ones and of the big ones."""
    if run.scene.get("scene", {}).get("kind", run.attrs.get("scene_kind")) != "drum" or "drum" not in run.scene:
        raise ValueError(f"{run.path}: not a drum run")
    if run.dim != 3:
        raise ValueError(f"{run.path}: views need 3D positions, the run has dim {run.dim}")
    n_frames = run.frames.n_frames
    if not -n_frames <= frame < n_frames:
        raise ValueError(f"{run.path}: frame {frame} out of range ({n_frames} frames)")
    for v in views:
        if v not in VIEWS:
            raise ValueError(f"unknown view {v!r}; choose from {', '.join(VIEWS)}")
    pos = run.frames.position[frame]
    species = run.frames.species[frame]
    diam = run.frames.diameter[frame]
    face, edge, lw = species_colors(species)
    drum = run.scene["drum"]

    name = run.attrs.get("scene_name") or run.scene.get("scene", {}).get("name", "?")
    t = float(run.frames.time[frame])
    when = (f"{t / run.rotation_period:.1f} rotations" if run.rotation_period else f"t = {t:.4g}")
    panels = [(v, np.ones(len(species), bool), f"all, {VIEW_LABELS[v]}") for v in views]
    if species_panels:
        panels += [("top", species == 0, "small only, from above"),
                   ("top", species == 1, "big only, from above")]

    aspect = float(drum["length"]) / float(drum["diameter"])
    width = 12.0
    fig = Figure(figsize=(width, len(panels) * (width / aspect + 0.5)), layout="constrained")
    axes = fig.subplots(len(panels), 1, squeeze=False)[:, 0]
    for ax, (view, keep, what) in zip(axes, panels):
        render_view(ax, pos[keep], diam[keep], face[keep], view, edgecolors=edge[keep], linewidths=lw[keep])
        _drum_outline(ax, drum)
        ax.set_title(f"{name}: {when}, {what}", fontsize=9)
        ax.set_xlabel("y (drum axis)", fontsize=8)
        ax.set_ylabel(VERTICAL_LABELS[view], fontsize=8)
        ax.tick_params(labelsize=7)
    return fig


def write_views(path, out, frame=-1, views=("top", "bottom"), species_panels=True, dpi=150):
    """Read a run, draw drum_views and save it as `out`; return the path written."""
    fig = drum_views(read_run(path), frame=frame, views=views, species_panels=species_panels)
    out = Path(out)
    fig.savefig(out, dpi=dpi)
    return out
