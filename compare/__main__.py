"""Command line: ``python3 -m compare quicklook OUT.h5 -o PLOT.png``.

Expected failures (missing file, wrong schema, not a drum) print one line to
stderr naming the file and exit with status 2, so scripts can tell them apart
from crashes (which keep their traceback).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never needs a display

from matplotlib.figure import Figure  # noqa: E402

from .reader import read_run  # noqa: E402
from .spacetime import SpaceTime  # noqa: E402


def quicklook(path, out, slice_width=None):
    """Write the space-time PNG of one run and return the path written."""
    run = read_run(path)
    st = SpaceTime(slice_width).compute(run)
    covered = float(st.time_rotations[-1]) if st.time_rotations.size else 0.0
    requested = run.scene.get("run", {}).get("rotations")
    rotations = f"{covered:.3g} rotations"
    if requested is not None and abs(float(requested) - covered) > 1e-6 * max(1.0, covered):
        rotations = f"{covered:.3g} of {float(requested):g} rotations"
    fig = Figure(figsize=(10, 4), layout="constrained")
    ax = st.plot(fig.add_subplot())
    ax.set_title(f"{run.attrs.get('engine', '?')}, scene {run.attrs.get('scene_name', '?')}: "
                 f"{rotations} (from {st.source})")
    out = Path(out)
    fig.savefig(out, dpi=150)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m compare",
                                     description="Analysis of granular-frames HDF5 runs.")
    sub = parser.add_subparsers(dest="command", required=True)
    q = sub.add_parser("quicklook", help="space-time plot of the drum's axial segregation")
    q.add_argument("run", help="HDF5 file written by an engine")
    q.add_argument("-o", "--output", help="PNG to write (default: RUN with suffix _spacetime.png)")
    q.add_argument("--slice-width", type=float, default=None,
                   help="slice width when recomputing from frames (default 1.0)")
    args = parser.parse_args(argv)

    if args.command == "quicklook":
        out = args.output or Path(args.run).with_name(Path(args.run).stem + "_spacetime.png")
        try:
            written = quicklook(args.run, out, args.slice_width)
        except (OSError, ValueError) as exc:
            msg = str(exc)
            if args.run not in msg:
                msg = f"{args.run}: {msg}"
            print(f"quicklook: error: {msg}", file=sys.stderr)
            return 2
        print(written)
    return 0


if __name__ == "__main__":
    sys.exit(main())
