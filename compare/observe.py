"""Every drum observable of one run, as a dict (for --json) and as figures.

One code path for every engine: only the common schema is read.
"""
from __future__ import annotations

from pathlib import Path


from ._common import clean_json
from .bands import BandCount, BandFormation
from .coulomb import CoulombCap, read_census
from .profile import AxialProfile
from .reader import read_run
from .spacetime import SpaceTime
from .surface import FreeSurface

DEFAULTS = {
    "formation.threshold": 3.0,
    "formation.window": 5.0,
    "formation.min_wavelength": 8.0,
    "bands.smoothing": 2.0,
    "bands.threshold": 4.0,
    "bands.min_width": 3,
    "bands.early_window": 20.0,
    "bands.final_window": 20.0,
    "surface.cell": 1.0,
    "surface.frames": 10,
    "surface.fit_window": 0.5,
    "surface.skip_rotations": 2.0,
}


def analyse(run, params=None):
    """Compute every observable; returns the observable objects by name."""
    p = dict(DEFAULTS, **(params or {}))
    if run.rotation_period is None:
        raise ValueError(f"{run.path}: not a drum run (scene_kind={run.attrs.get('scene_kind')!r})")
    if run.frames.n_frames == 0:
        raise ValueError(f"{run.path}: no snapshots in the file")
    out = {"spacetime": SpaceTime().compute(run), "profile": AxialProfile().compute(run)}
    out["formation"] = BandFormation(p["formation.threshold"], p["formation.window"],
                                     p["formation.min_wavelength"]).compute(run)
    out["bands"] = BandCount(p["bands.smoothing"], p["bands.threshold"], int(p["bands.min_width"]),
                             p["bands.early_window"], p["bands.final_window"]).compute(
                                 run, start=out["formation"].formation_time)
    out["surface"] = FreeSurface(cell=p["surface.cell"], frames=int(p["surface.frames"]),
                                 fit_window=p["surface.fit_window"],
                                 skip_rotations=p["surface.skip_rotations"]).compute(run)
    return out


def observe(path, params=None, reference=None):
    """Every observable of the run in ``path`` as a JSON-ready dict (drum or
    shaken box; ``reference``: for a box, a run without the big disk)."""
    run = read_run(path)
    if run.attrs.get("scene_kind") == "shaken_box":
        from .box import observe_box
        return observe_box(run, reference=reference)
    obs = analyse(run, params)
    st = obs["spacetime"]
    t = st.time_rotations
    d = {
        "file": str(path),
        "engine": run.attrs.get("engine"),
        "engine_version": run.attrs.get("engine_version"),
        "scene": run.attrs.get("scene_name"),
        "particles": int(run.frames.n_particles),
        "rotations_run": float(t[-1]) if t.size else 0.0,
        "rotations_requested": run.scene.get("run", {}).get("rotations"),
        "profile": {"source": st.source, "samples": int(t.size),
                    "engine_vs_frames_max_difference": obs["profile"].engine_max_difference,
                    "frames_compared": obs["profile"].frames_compared},
        "formation": obs["formation"].as_dict(),
        "bands": obs["bands"].as_dict(),
    }
    if "surface" in obs:
        d["surface"] = obs["surface"].as_dict()
    if read_census(run.path) is not None:
        skip = float((params or {}).get("surface.skip_rotations", DEFAULTS["surface.skip_rotations"]))
        d["coulomb"] = CoulombCap(skip * run.rotation_period).compute(run.path).as_dict()
    return clean_json(d)


def plot_all(path, outdir, params=None):
    """Write spacetime.png, bands.png and surface.png for one run; returns the paths."""
    from matplotlib.figure import Figure

    run = read_run(path)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    if run.attrs.get("scene_kind") == "shaken_box":
        return _plot_box(run, outdir)
    obs = analyse(run, params)
    name = f"{run.attrs.get('engine', '?')}, scene {run.attrs.get('scene_name', '?')}"
    written = []

    fig = Figure(figsize=(10, 4), layout="constrained")
    ax = obs["spacetime"].plot(fig.add_subplot())
    ft = obs["formation"].formation_time
    ax.set_title(f"{name}: {obs['spacetime'].time_rotations[-1]:.0f} rotations; bands "
                 f"{obs['bands'].early}->{obs['bands'].final}"
                 + (f", formed at {ft:.0f}" if ft is not None else ", no bands formed"))
    written.append(outdir / "spacetime.png")
    fig.savefig(written[-1], dpi=150)

    fig = Figure(figsize=(8, 6), layout="constrained")
    a1, a2 = fig.subplots(2, 1, sharex=True)
    obs["formation"].plot(a1)
    obs["bands"].plot(a2)
    a1.set_title(name)
    written.append(outdir / "bands.png")
    fig.savefig(written[-1], dpi=120)

    if "surface" in obs:
        fig = Figure(figsize=(6, 5), layout="constrained")
        obs["surface"].plot(fig.add_subplot())
        written.append(outdir / "surface.png")
        fig.savefig(written[-1], dpi=120)
    return written


def _plot_box(run, outdir):
    """big_disk_height.png (Fig. 4), flux.png (Fig. 3), velocity.png (Fig. 1)."""
    from matplotlib.figure import Figure

    from .box import BigDiskHeight, ConvectiveFlux, VelocityField, read_trace

    written = []
    name = f"{run.attrs.get('engine', '?')}, {run.attrs.get('scene_name', '?')}"
    parts = [("flux.png", ConvectiveFlux, (5, 6)), ("velocity.png", VelocityField, (6, 7))]
    if read_trace(run) is not None:
        parts.insert(0, ("big_disk_height.png", BigDiskHeight, (8, 4)))
    for fname, cls, size in parts:
        fig = Figure(figsize=size, layout="constrained")
        ax = cls().compute(run).plot(fig.add_subplot())
        ax.set_title(f"{name}: {ax.get_title()}", fontsize=9)
        written.append(outdir / fname)
        fig.savefig(written[-1], dpi=110)
    return written
