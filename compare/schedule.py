"""Output schedules every engine driver shares (lammps_cases, yade_cases),
so that every engine writes frames at the native engine's steps
(engine/drum.cpp, engine/box.cpp), and the shaker's closed form
(integrate/motion.hpp, ShakerMotion) for one time at a time."""

from __future__ import annotations

import math

import numpy as np


def lround(x: float) -> int:
    return int(math.floor(x + 0.5))


def drum_schedule(scene: dict):
    """(total steps, snapshot steps, profile steps, slice edges) as lammps_cases/drum.py."""
    drum, run = scene["drum"], scene["run"]
    omega, dt = float(drum["omega"]), float(scene["integrator"]["dt"])
    length = float(drum["length"])
    period = 2 * math.pi / omega
    steps_per = lambda rot: lround(rot * period / dt)  # engine/drum.cpp: DrumScene::steps_per
    total = steps_per(float(run["rotations"]))
    width = float(run.get("profile_slice_width", 1.0))
    ns = max(1, lround(length / width))
    edges = -0.5 * length + length * np.arange(ns + 1) / ns
    snap_steps, prof_steps = set(), set()
    for every, target in ((float(run["snapshot_every"]), snap_steps), (float(run["profile_every"]), prof_steps)):
        j = 0
        while steps_per(j * every) <= total:
            target.add(steps_per(j * every))
            j += 1
        target.add(total)
    # run.final_snapshots: N - 1 more before the final state, run.final_snapshot_every apart
    rotations, gap = float(run["rotations"]), float(run.get("final_snapshot_every", 5.0))
    snap_steps |= {steps_per(rotations - k * gap) for k in range(1, int(run.get("final_snapshots", 0)))}
    return total, snap_steps, prof_steps, edges



def particles_schedule(scene: dict):
    """(total steps, snapshot steps) of a particles scene, as engine/particles.cpp
    writes its frames: at each multiple of run.snapshot_every rounded to the
    nearest step (ParticlesScene::steps_per), and the last step."""
    run, dt = scene["run"], float(scene["integrator"]["dt"])
    steps_per = lambda t: lround(t / dt)  # noqa: E731
    total = steps_per(float(run["duration"]))
    every = float(run.get("snapshot_every", float(run["duration"]) / 100.0))
    snaps, j = set(), 0
    while steps_per(j * every) <= total:
        snaps.add(steps_per(j * every))
        j += 1
    snaps.add(total)
    return total, snaps

class Shaker:
    """y_box(t) = A s(t) sin(phi(t)) and its velocity, as ShakerMotion
    (integrate/motion.hpp): phi = 2 pi int f dt' from the start of shaking,
    f ramped linearly from f0 to f1 over [ramp_start, ramp_start + ramp_time]
    after the start; s rises linearly over the first startup_cycles cycles."""

    def __init__(self, scene: dict):
        sh = scene["shaking"]
        self.amplitude = float(sh["amplitude"])
        self.f0 = float(sh["frequency"])
        self.f1 = float(sh.get("ramp_to", self.f0))
        self.start = float(scene["run"]["settle"])
        self.ramp_start = float(sh.get("ramp_start", 0.0))
        self.ramp_time = float(sh.get("ramp_time", 0.0))
        self.startup_cycles = float(sh.get("startup_cycles", 2.0))

    def frequency(self, t: float) -> float:
        s = t - self.start - self.ramp_start
        if self.ramp_time <= 0.0 or s <= 0.0:
            return self.f1 if (s > 0.0 and self.ramp_time <= 0.0) else self.f0
        return self.f1 if s >= self.ramp_time else self.f0 + (self.f1 - self.f0) * s / self.ramp_time

    def phase(self, t: float) -> float:
        u = t - self.start
        if u <= 0.0:
            return 0.0
        if self.ramp_time <= 0.0:
            return 2.0 * math.pi * self.f0 * u
        a = min(u, self.ramp_start)
        s = min(max(u - self.ramp_start, 0.0), self.ramp_time)
        b = max(0.0, u - self.ramp_start - self.ramp_time)
        return 2.0 * math.pi * (self.f0 * a + self.f0 * s + 0.5 * (self.f1 - self.f0) * s * s / self.ramp_time
                                + self.f1 * b)

    def cycle(self, t: float) -> float:  # BoxScene::cycle
        return self.phase(t) / (2.0 * math.pi)

    def envelope(self, t: float) -> float:
        if self.startup_cycles <= 0.0:
            return 1.0 if t > self.start else 0.0
        return min(max(self.phase(t) / (2.0 * math.pi * self.startup_cycles), 0.0), 1.0)

    def y(self, t: float) -> float:
        return self.amplitude * self.envelope(t) * math.sin(self.phase(t))

    def vy(self, t: float) -> float:
        if t <= self.start:
            return 0.0
        omega, ph = 2.0 * math.pi * self.frequency(t), self.phase(t)
        v = self.amplitude * self.envelope(t) * math.cos(ph) * omega
        if self.startup_cycles > 0.0 and ph < 2.0 * math.pi * self.startup_cycles:
            v += self.amplitude * math.sin(ph) * omega / (2.0 * math.pi * self.startup_cycles)
        return v


def box_schedule(scene: dict):
    """(total, settle steps, snapshot steps, trace steps) as engine/box.cpp and
    lammps_cases/box.py schedule them: a snapshot at the first step of each new
    multiple of snapshot_every_cycles, a trace sample at each new
    1/trace_per_cycle of a cycle (cycle = phase / 2 pi)."""
    run = scene["run"]
    dt = float(scene["integrator"]["dt"])
    settle, duration = float(run["settle"]), float(run["duration"])
    total = lround((settle + duration) / dt)
    settle_steps = lround(settle / dt)
    per_snap = float(run.get("snapshot_every_cycles", 1.0))
    per_cycle = int(run.get("trace_per_cycle", 20))
    shaker = Shaker(scene)
    snaps, traces = {0, settle_steps, total}, set()
    snap_k = trace_k = 0
    for k in range(settle_steps + 1, total + 1):
        cyc = shaker.cycle(k * dt)
        if cyc >= (snap_k + 1) * per_snap:
            snaps.add(k)
            snap_k = int(math.floor(cyc / per_snap))
        if cyc * per_cycle >= trace_k + 1:
            traces.add(k)
            trace_k = int(math.floor(cyc * per_cycle))
    return total, settle_steps, snaps, traces
