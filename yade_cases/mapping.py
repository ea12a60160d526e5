"""The native linear law (contact/linear.hpp) and the Poeschel-Herrmann box law
as YADE ViscElMat materials (Ip2_ViscElMat_ViscElMat_ViscElPhys in its
explicit kn/cn/ks/cs mode, Law2_ScGeom_ViscElPhys_Basic). Plain Python: the
launcher and the tests import it; the YADE scripts import it too.

YADE combines the two materials of a contact as 1/(1/a + 1/b), a value of 0
counting as absent (0 with b gives b; ViscoelasticPM.cpp,
contactParameterCalculation). So:

  particle i of species s:  kn = 2 kn_ss,  cn = g_ss m_i,  cs = xg_ss g_ss m_i
    -> a same-species pair gets kn_ss, g_ss m_i m_j/(m_i + m_j) and
       xg_ss g_ss m_eff: exactly the linear law, for any masses;
       a small-big pair gets whatever the mixing gives (recorded);
  wall material of species s (absolute values): the linear law wants
    kn_w[s], g_w[s] m_i, xg_w[s] g_w[s] m_i (wall contacts: m_eff = m_i);
    with the particle value P and the wanted value want,
    W = 1/(1/want - 1/P) if want < P, else 0 (absent: the wall contact then
    gets P; listed in "infeasible"). The particles of a drum species are not
    of one mass (particles.diameter_spread: masses spread by about +-30 %),
    so W is computed for a reference mass per species (the native engine
    takes the nominal mass, (d - spread/2)^3, = the linear law's wall m_eff);
    a particle of mass m_i != m_ref gets g_w m_i only approximately
    (wall_spread() gives the range of got/want over the particles).

The result has the layout of the native engine's derived["viscel_law"]
(granular init; scene/law_mapping.cpp, map_linear_to_viscel), which the drum
case uses when present:

  {"materials": {"small": {"kn", "cn_per_mass", "cs_per_mass"}, "big": {...}},
   "wall_materials": {"small": {"kn", "cn", "cs"}, "big": {...}},
   "mean_mass": {"small": m_s, "big": m_b},      the reference masses
   "infeasible": ["wall.small.cs", ...]}
"""

from __future__ import annotations

import math

import numpy as np

SPECIES = ("small", "big")
PAIR_OF = {"small": "small_small", "big": "big_big"}


def harmonic(a: float, b: float) -> float:
    """YADE's contactParameterCalculation: 1/(1/a + 1/b), 0 counting as absent."""
    s = (1.0 / a if a else 0.0) + (1.0 / b if b else 0.0)
    return 1.0 / s if s else 0.0


def wall_value(want: float, particle: float):
    """Wall material value W with harmonic(W, particle) == want; (W, feasible)."""
    if want > 0.0 and want < particle:
        return 1.0 / (1.0 / want - 1.0 / particle), True
    if want == particle:  # W = infinity; 0 (absent) gives the particle value, which is exact
        return 0.0, True
    return 0.0, False


def viscel_from_linear(lin: dict, masses: dict) -> dict:
    """derived["linear_law"] (granular init) -> the viscel_law record.
    masses: {"small": m_s, "big": m_b}, the reference mass per species."""
    law = {"materials": {}, "wall_materials": {}, "mean_mass": {s: float(masses[s]) for s in SPECIES},
           "infeasible": []}
    for s in SPECIES:
        c = lin["pair"][PAIR_OF[s]]
        law["materials"][s] = {"kn": 2.0 * float(c["kn"]), "cn_per_mass": float(c["gamma_n"]),
                               "cs_per_mass": float(c["xgamma_t"]) * float(c["gamma_n"])}
    for s in SPECIES:
        m = float(masses[s])
        p = particle_material(law, s, m)
        want = wall_wanted(lin, s, m)
        law["wall_materials"][s] = {}
        for key in ("kn", "cn", "cs"):
            val, ok = wall_value(want[key], p[key])
            law["wall_materials"][s][key] = val
            if not ok:
                law["infeasible"].append(f"wall.{s}.{key}")
    return law


def wall_wanted(lin: dict, species: str, mass: float) -> dict:
    """The linear law's wall contact (m_eff = m_i) as absolute kn, cn, cs."""
    w = lin["wall"][species]
    return {"kn": float(w["kn"]), "cn": float(w["gamma_n"]) * mass,
            "cs": float(w["xgamma_t"]) * float(w["gamma_n"]) * mass}


def particle_material(law: dict, species: str, mass: float) -> dict:
    """kn, cn, cs of one particle's ViscElMat."""
    p = law["materials"][species]
    return {"kn": float(p["kn"]), "cn": float(p["cn_per_mass"]) * mass, "cs": float(p["cs_per_mass"]) * mass}


def mismatch(law: dict, lin: dict) -> dict:
    """The infeasible keys with what the linear law wants and what YADE's mixing
    gives, at the reference masses."""
    out = {}
    for key in law.get("infeasible", []):
        _, s, k = key.split(".")
        m = float(law["mean_mass"][s])
        out[key] = {"want": wall_wanted(lin, s, m)[k],
                    "got": harmonic(particle_material(law, s, m)[k], float(law["wall_materials"][s][k]))}
    return out


def pair_values(law: dict, lin: dict) -> dict:
    """What YADE's mixing gives at the reference masses, beside what the linear
    law wants (kn, cn = g_n m_eff, cs = xg_t g_n m_eff), for every pair and wall."""
    ref = {s: float(law["mean_mass"][s]) for s in SPECIES}
    out = {}
    for a, b, key in (("small", "small", "small_small"), ("small", "big", "small_big"), ("big", "big", "big_big")):
        pa, pb = particle_material(law, a, ref[a]), particle_material(law, b, ref[b])
        c = lin["pair"][key]
        meff = ref[a] * ref[b] / (ref[a] + ref[b])
        want = {"kn": float(c["kn"]), "cn": float(c["gamma_n"]) * meff,
                "cs": float(c["xgamma_t"]) * float(c["gamma_n"]) * meff}
        out[key] = {k: {"want": want[k], "got": harmonic(pa[k], pb[k])} for k in ("kn", "cn", "cs")}
    for s in SPECIES:
        p = particle_material(law, s, ref[s])
        want = wall_wanted(lin, s, ref[s])
        out[f"wall_{s}"] = {k: {"want": want[k], "got": harmonic(p[k], float(law["wall_materials"][s][k]))}
                            for k in ("kn", "cn", "cs")}
    return out


def wall_spread(law: dict, lin: dict, species, mass) -> dict:
    """Range [min, max] of got/want of the wall contacts' cn and cs over the
    particles (a particle's mass differs from its species' reference mass)."""
    out = {}
    species, mass = np.asarray(species), np.asarray(mass, dtype=float)
    for k, s in enumerate(SPECIES):
        m = mass[species == k]
        if not len(m):
            continue
        res = {}
        for key in ("cn", "cs"):
            want = np.array([wall_wanted(lin, s, mi)[key] for mi in m])
            got = np.array([harmonic(particle_material(law, s, mi)[key], float(law["wall_materials"][s][key]))
                            for mi in m])
            ratio = np.divide(got, want, out=np.ones_like(got), where=want > 0)
            res[key] = [float(ratio.min()), float(ratio.max())]
        out[s] = res
    return out


def check_viscel_law(law: dict) -> None:
    """The layout viscel_from_linear writes (and derived["viscel_law"] has)."""
    try:
        for s in SPECIES:
            for k in ("kn", "cn_per_mass", "cs_per_mass"):
                float(law["materials"][s][k])
            for k in ("kn", "cn", "cs"):
                float(law["wall_materials"][s][k])
            float(law["mean_mass"][s])
        list(law["infeasible"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"derived[\"viscel_law\"] does not have the expected layout ({exc!r}); "
                         "see yade_cases/mapping.py") from exc


def box_material(scene: dict, species: int, mass: float) -> dict:
    """One box particle's ViscElMat: kn = 2 Y, cn = g_N m_i, cs = g_S m_i, so a pair
    gets Y, g_N m_eff, g_S m_eff (the Poeschel-Herrmann law without its Coulomb
    cap). Wall particles with box.wall_mass = "infinite": cn = cs = 0 (absent),
    so a grain-wall contact gets g_N m_i, g_S m_i (m_eff = m_i)."""
    c = scene["contact"]
    kn = 2.0 * float(c["young"])
    if species == 2 and scene.get("box", {}).get("wall_mass", "particle") == "infinite":
        return {"kn": kn, "cn": 0.0, "cs": 0.0}
    return {"kn": kn, "cn": float(c["gamma_n"]) * mass, "cs": float(c["gamma_s"]) * mass}


def polygon_radius_error(radius: float, segments: int) -> float:
    """Vertices on the circle of radius R: the sides lie at R cos(pi/N)."""
    return radius * (1.0 - math.cos(math.pi / segments))
