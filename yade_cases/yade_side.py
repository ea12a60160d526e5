"""Helpers for the YADE scripts (drum_case.py, box_case.py, two_body.py): only
importable inside the `yade` launcher."""

from __future__ import annotations

import os
import shutil
import sys
import time
import traceback

import numpy as np

import yade
from yade import O


def version() -> str:
    return str(yade.config.version)


def run_steps(n: int) -> None:
    """O.run(n, True), guarded: O.run(0, True) never returns (ENGINES.md)."""
    if n > 0:
        O.run(int(n), True)


def states(ids, angular=True):
    """Positions, velocities (and angular velocities) of the bodies ids, (n, 3) each."""
    bodies = O.bodies
    x = np.empty((len(ids), 3))
    v = np.empty((len(ids), 3))
    w = np.empty((len(ids), 3)) if angular else None
    for k, i in enumerate(ids):
        st = bodies[int(i)].state
        x[k] = tuple(st.pos)
        v[k] = tuple(st.vel)
        if angular:
            w[k] = tuple(st.angVel)
    return x, v, w


def forces(ids):
    f = np.empty((len(ids), 3))
    for k, i in enumerate(ids):
        f[k] = tuple(O.forces.f(int(i)))
    return f


class Progress:
    def __init__(self, n_particles: int, quiet: bool):
        self.n, self.quiet = n_particles, quiet
        self.t0 = time.perf_counter()
        self.last = 0.0
        self.mark_step, self.mark_clock = None, None

    def mark(self, step: int):
        """From here on the speed is also timed alone (bench: settling excluded)."""
        self.mark_step, self.mark_clock = step, time.perf_counter()

    def show(self, text: str, steps_done: int, force=False):
        if self.quiet:
            return
        now = time.perf_counter()
        if force or now - self.last > 0.5:
            self.last = now
            el = max(now - self.t0, 1e-9)
            print(f"\r  {text}  {steps_done * self.n / el:.3g} particle-steps/s   ", end="", file=sys.stderr,
                  flush=True)

    def finish(self, out, total_steps: int):
        """Records the speed in the output and closes it; returns particle-steps/s."""
        end = time.perf_counter()
        elapsed = end - self.t0
        rate = total_steps * self.n / elapsed if elapsed > 0 else 0.0
        out.h5.attrs["wall_seconds"] = elapsed
        out.h5.attrs["atom_steps_per_second"] = rate
        if self.mark_clock is not None and total_steps > self.mark_step:
            out.h5.attrs["timed_from_step"] = self.mark_step
            out.h5.attrs["timed_atom_steps_per_second"] = (total_steps - self.mark_step) * self.n / (end - self.mark_clock)
        out.close()
        if not self.quiet:
            print(f"\ndone: {total_steps} steps in {elapsed:.1f} s, {rate:.3g} particle-steps/s", file=sys.stderr)
        return rate


def exit_with(run) -> None:
    """Runs run() (a script's work, returning its exit status), prints any
    exception's traceback, removes the temporary directory YADE made for this
    process (/tmp/yade-XXXXXX, which YADE leaves behind, whatever TMPDIR says)
    and exits with the status (1 on an exception)."""
    try:
        code = run()
    except Exception:  # noqa: BLE001 - report and exit non-zero
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    tmp = os.path.dirname(O.tmpFilename())
    if os.path.basename(tmp).startswith("yade-"):
        shutil.rmtree(tmp, ignore_errors=True)
    sys.exit(code)


def script_main(main, script: str) -> None:
    """Entry point of a case script run as `yade -n -x SCRIPT WORKDIR OUT.h5`:
    runs main(workdir, out) and exits with its status (exit_with; 2 on a
    wrong command line)."""
    if len(sys.argv) != 3:
        print(f"usage: yade -n -x yade_cases/{script} WORKDIR OUT.h5", file=sys.stderr)
        sys.exit(2)
    exit_with(lambda: main(sys.argv[1], sys.argv[2]))
