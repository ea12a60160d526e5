#include "scene/law_mapping.hpp"

#include "contact/laws.hpp"

#include <cmath>
#include <stdexcept>

namespace granular {

Collision rapaport_collision(double dij, double meff, double gamma_n, double v) {
  const double rc = RapaportLaw<3>::kCutFactor * dij;
  // d/dt (r, u) = (u, (f_v(r) - gamma_n u) / m_eff), classical RK4 with a step
  // far below the contact time; the exit is located by cubic Hermite
  // interpolation between the last two steps.
  auto acc = [&](double r, double u) { return RapaportLaw<3>::normal(1.0 / r, dij, u, gamma_n) / meff; };
  const double h = 2e-5 * dij / std::max(v, 0.05);
  double r = rc, u = -v, t = 0.0;
  for (long k = 0; k < 10000000L; ++k) {  // 200 d_ij / v of contact: far beyond any rebound
    const double k1r = u, k1u = acc(r, u);
    const double k2r = u + 0.5 * h * k1u, k2u = acc(r + 0.5 * h * k1r, u + 0.5 * h * k1u);
    const double k3r = u + 0.5 * h * k2u, k3u = acc(r + 0.5 * h * k2r, u + 0.5 * h * k2u);
    const double k4r = u + h * k3u, k4u = acc(r + h * k3r, u + h * k3u);
    const double rn = r + h / 6 * (k1r + 2 * k2r + 2 * k3r + k4r);
    const double un = u + h / 6 * (k1u + 2 * k2u + 2 * k3u + k4u);
    if (k > 0 && rn >= rc) {
      // Hermite cubic through (0, r, u h) and (1, rn, un h); bisect for r(s) = rc.
      const double a0 = r, a1 = u * h;
      const double a2 = 3 * (rn - r) - (2 * u + un) * h, a3 = 2 * (r - rn) + (u + un) * h;
      double lo = 0.0, hi = 1.0;
      for (int it = 0; it < 60; ++it) {
        const double s = 0.5 * (lo + hi);
        (a0 + s * (a1 + s * (a2 + s * a3)) < rc ? lo : hi) = s;
      }
      const double s = 0.5 * (lo + hi);
      const double us = (a1 + s * (2 * a2 + 3 * s * a3)) / h;
      return {us / v, t + s * h};
    }
    r = rn;
    u = un;
    t += h;
  }
  throw MappingError("a head-on collision of diameter " + std::to_string(dij) + " (m_eff " + std::to_string(meff) +
                     ") at impact speed " + std::to_string(v) + " never rebounds with contact.gamma_n = " +
                     std::to_string(gamma_n) + " (overdamped): no linear spring-dashpot has restitution 0");
}

Collision linear_collision(double kn, double gamma_n) {
  const double beta = 0.5 * gamma_n;
  const double w2 = kn - beta * beta;
  if (w2 <= 0.0) return {0.0, INFINITY};  // overdamped: no rebound
  const double tc = M_PI / std::sqrt(w2);
  return {std::exp(-beta * tc), tc};
}

double rapaport_overlap(double dij, double force) {
  const double rc = RapaportLaw<3>::kCutFactor * dij;
  double lo = 0.5 * dij, hi = rc;  // f_v decreases from lo to 0 at hi
  for (int it = 0; it < 200; ++it) {
    const double r = 0.5 * (lo + hi);
    (RapaportLaw<3>::normal(1.0 / r, dij, 0.0, 0.0) > force ? lo : hi) = r;
  }
  return rc - 0.5 * (lo + hi);
}

LinearNormal linear_matching(const Collision& c) {
  const double w = M_PI / c.contact_time, beta = -std::log(c.restitution) / c.contact_time;
  return {w * w + beta * beta, 2.0 * beta};
}

MappingInputs mapping_inputs(const DrumScene& s) {
  MappingInputs in = MappingInputs::parameters_of(s);
  in.d[0] = s.small_diameter - 0.5 * s.diameter_spread;
  in.d[1] = s.big_diameter - 0.5 * s.diameter_spread;
  in.load_height = 0.5 * s.diameter;
  return in;
}

double rapaport_stiffness(double dij, double force) {
  if (force > 0.0) return force / rapaport_overlap(dij, force);
  const double rc = RapaportLaw<3>::kCutFactor * dij;
  return 72.0 / (rc * rc);
}

LinearMapping map_rapaport_to_linear(const MappingInputs& in) {
  LinearMapping m;
  m.impact_speed = in.impact_speed;
  m.diameter_scale = RapaportLaw<3>::kCutFactor;
  m.wall_inset = 0.5 * RapaportLaw<3>::kCutFactor * in.wall_diameter;
  const RapaportLaw<3> rap = in.rapaport();
  const double* d = in.d;
  const double mass[2] = {d[0] * d[0] * d[0], d[1] * d[1] * d[1]};
  // F*: the weight of a column of mean grains load_height high.
  const double dbar = 0.5 * (d[0] + d[1]), mbar = 0.5 * (mass[0] + mass[1]);
  m.static_load = in.gravity * mbar * in.load_height / dbar;
  auto fill = [&](LinearLaw<3>::Coeff& c, double dij, const Collision& col, double meff,
                  const RapaportLaw<3>::Friction& fr) {
    // k_n: the same overlap under F*; g_n: the same restitution e. For the
    // linear law e = exp(-beta pi / omega), omega^2 = k_n/m_eff - beta^2,
    // beta = g_n/2, so beta = |ln e| sqrt(k_n/m_eff) / sqrt(pi^2 + ln^2 e).
    c.kn = rapaport_stiffness(dij, m.static_load);
    const double le = std::log(col.restitution), k1 = c.kn / meff;
    c.gamma_n = 2.0 * std::abs(le) * std::sqrt(k1) / std::sqrt(M_PI * M_PI + le * le);
    // Rapaport's sliding force gamma_s |v_s| is not mass weighted; LAMMPS's is
    // x_t g_n m_eff |v_t|, so x_t = gamma_s / (g_n m_eff) at the mean masses.
    c.xgamma_t = c.gamma_n > 0 ? fr.gamma_s / (c.gamma_n * meff) : 0.0;
    c.mu = fr.mu;
    return linear_collision(k1, c.gamma_n);
  };
  for (int a = 0; a < 2; ++a)
    for (int b = a; b < 2; ++b) {
      const int k = a + b;  // 0 ss, 1 sb, 2 bb
      const double meff = mass[a] * mass[b] / (mass[a] + mass[b]);
      m.pair_meff[k] = meff;
      const double dij = 0.5 * (d[a] + d[b]);
      m.pair_collision[k] = rapaport_collision(dij, meff, in.gamma_n, in.impact_speed);
      m.pair_linear[k] = fill(m.law.pair[a * 2 + b], dij, m.pair_collision[k], meff, rap.pair[a * 2 + b]);
      m.law.pair[b * 2 + a] = m.law.pair[a * 2 + b];
    }
  for (int a = 0; a < 2; ++a) {
    m.wall_meff[a] = mass[a];
    const double diw = 0.5 * (d[a] + in.wall_diameter);
    m.wall_collision[a] = rapaport_collision(diw, mass[a], in.gamma_n, in.impact_speed);
    m.wall_linear[a] = fill(m.law.wall[a], diw, m.wall_collision[a], mass[a], rap.wall[a]);
  }
  return m;
}

double linear_overlap_fraction(const MappingInputs& in, const LinearMapping& m, double v) {
  double worst = 0.0;
  for (int a = 0; a < 2; ++a) {
    for (int b = a; b < 2; ++b) {
      const double reach = m.diameter_scale * 0.5 * (in.d[a] + in.d[b]);
      worst = std::max(worst, v * std::sqrt(m.pair_meff[a + b] / m.law.pair[a * 2 + b].kn) / reach);
    }
    const double reach = m.diameter_scale * 0.5 * (in.d[a] + in.wall_diameter);
    worst = std::max(worst, v * std::sqrt(m.wall_meff[a] / m.law.wall[a].kn) / reach);
  }
  return worst;
}

ViscElMapping map_linear_to_viscel(const MappingInputs& in, const LinearMapping& lin) {
  ViscElMapping v;
  const double* d = in.d;
  const char* name[2] = {"small", "big"};
  for (int a = 0; a < 2; ++a) {
    v.mean_mass[a] = d[a] * d[a] * d[a];
    const auto& c = lin.law.pair[a * 2 + a];
    // mix(x m, x m) = x m / 2 = x m_eff for equal masses: the same-species pair exactly
    v.law.mat[a] = {2.0 * c.kn, c.gamma_n, c.xgamma_t * c.gamma_n};
  }
  for (int a = 0; a < 2; ++a) {
    const auto& mat = v.law.mat[a];
    const auto& w = lin.law.wall[a];
    const double m = v.mean_mass[a];
    // fix wall/gran: m_eff = m_i, so the wanted wall values are absolute at the mean mass
    const double want[3] = {w.kn, w.gamma_n * m, w.xgamma_t * w.gamma_n * m};
    const double have[3] = {mat.kn, mat.cn_per_mass * m, mat.cs_per_mass * m};
    const char* key[3] = {"kn", "cn", "cs"};
    double got[3];
    for (int k = 0; k < 3; ++k) {
      if (want[k] > 0.0 && want[k] < have[k]) {
        got[k] = 1.0 / (1.0 / want[k] - 1.0 / have[k]);
      } else {
        got[k] = 0.0;
        if (want[k] != have[k]) v.infeasible.push_back(std::string("wall.") + name[a] + "." + key[k]);
      }
    }
    v.law.wall[a] = {got[0], got[1], got[2]};
  }
  // The capped law's Coulomb coefficients, kept for the census only.
  for (int a = 0; a < 2; ++a) {
    v.law.wall_mu_ref[a] = lin.law.wall[a].mu;
    for (int b = 0; b < 2; ++b) v.law.mu_ref[a * ViscElLaw<3>::kSpecies + b] = lin.law.pair[a * 2 + b].mu;
  }
  return v;
}

void check_law_settable(const std::string& law, const MappingInputs& in) {
  with_law(RapaportSceneLaws<MappingInputs>{}, law, Damping::normal,
           [&](auto tag) { (void)decltype(tag)::type::from_rapaport(in); });
}

void check_law_settable(SceneFile& f, const std::string& law, const MappingInputs& in) {
  try {
    check_law_settable(law, in);
  } catch (const MappingError& e) {
    f.fail("contact.law", "\"" + law + "\" is mapped from Rapaport's law, which cannot be done here: " + e.what());
  }
}

}  // namespace granular
