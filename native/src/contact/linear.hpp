// Linear spring-dashpot with viscous tangential friction capped by Coulomb,
// computed exactly as LAMMPS (29 Sep 2021) computes
//   pair_style granular  hooke k_n g_n  damping mass_velocity
//                        tangential linear_nohistory x_t mu
// and, for walls, fix wall/gran/region with the same keywords. Per type pair
// (and per species for the walls), for particles i, j with radii R_i, R_j
// (LAMMPS radius = d/2), n = (r_i - r_j)/r, delta = R_i + R_j - r > 0:
//
//   m_eff = m_i m_j / (m_i + m_j)                 (wall: m_eff = m_i)
//   F_n   = k_n delta - g_n m_eff (v_ij . n)      no clipping of an attractive F_n
//   v_t   = v_ij - (v_ij . n) n - (R_i w_i + R_j w_j) x n     (wall: R_i w_i)
//   F_t   = -min(x_t g_n m_eff |v_t|, mu |F_n|) v_t/|v_t|
//   torque on i: -(R_i - delta/2) n x F_t,  on j: -(R_j - delta/2) n x F_t
//   torque from a wall: -R_i n x F_t          (fix wall/gran: lever R_i)
//
// Checked against the LAMMPS binary by tests/python/test_lammps_agreement.py.
// The map from Rapaport's law to these coefficients is scene/law_mapping.hpp
// (docs/model_mapping.md).
#pragma once
#include <array>
#include <cmath>
#include <type_traits>

#include "contact/lane.hpp"
#include "contact/law_paths.hpp"

namespace granular {

template <int Dim>
struct LinearLaw : LawPaths<LinearLaw<Dim>, Dim> {
  static constexpr const char* kName = "linear";  // contact.law
  static constexpr bool kInDim = true;            // written for 2D and 3D
  static constexpr bool kVectorised = true;       // pairs and walls in SIMD batches
  static constexpr int kSpecies = 2;

  struct Coeff {
    double kn = 0.0;       // k_n, force per overlap
    double gamma_n = 0.0;  // g_n, per unit effective mass (damping mass_velocity)
    double xgamma_t = 0.0;  // x_t: tangential damping = x_t g_n m_eff
    double mu = 0.0;        // Coulomb cap mu |F_n|
  };

  std::array<Coeff, kSpecies * kSpecies> pair{};  // [c_i * kSpecies + c_j]
  std::array<Coeff, kSpecies> wall{};             // [c_i]

  // The Coulomb coefficient of a contact (engine/coulomb_census.hpp).
  double coulomb_mu(int ci, int cj) const { return pair[ci * kSpecies + cj].mu; }
  double wall_coulomb_mu(int ci) const { return wall[ci].mu; }

  // Contact when r < R_i + R_j; a smooth wall has zero thickness (d_wall = 0).
  // range = kRangeFactor * (d_i + d_j): the neighbour build tests it in vector
  // lanes in this form (neighbor/range_scan.hpp).
  static constexpr double kRangeFactor = 0.5;
  GRANULAR_HD static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  // A pair contact (contact/lane.hpp).
  GRANULAR_HD void pair_lane(const PairContact<Dim>& c, PairForce<Dim>& o) const {
    constexpr int kA = kAngDim<Dim>;
    const Coeff& k = pair[c.ci * kSpecies + c.cj];
    const double r = std::sqrt(c.r2);
    double n[Dim], vt[Dim], fs[Dim], wr[kA], wxn[Dim], m[kA];
    for (int a = 0; a < Dim; ++a) n[a] = c.dr[a] / r;
    const double ri = 0.5 * c.di, rj = 0.5 * c.dj;
    const double delta = ri + rj - r;
    const double meff = 1.0 / (c.inv_mi + c.inv_mj);
    double vn = 0.0;
    for (int a = 0; a < Dim; ++a) vn += c.v[a] * n[a];
    const double damp_n = k.gamma_n * meff;
    const double fn = k.kn * delta - damp_n * vn;  // F_n
    for (int a = 0; a < kA; ++a) wr[a] = ri * c.wi[a] + rj * c.wj[a];
    spin_cross_c(wr, n, wxn);
    double vt2 = 0.0;
    for (int a = 0; a < Dim; ++a) {
      vt[a] = c.v[a] - vn * n[a] - wxn[a];  // v_t
      vt2 += vt[a] * vt[a];
    }
    capped_friction_c(vt, vt2, k.xgamma_t * damp_n, k.mu * std::abs(fn), fs);  // F_t
    moment_c(n, fs, m);
    for (int a = 0; a < Dim; ++a) o.f[a] = fn * n[a] + fs[a];
    for (int a = 0; a < kA; ++a) {
      o.ti[a] = -(ri - 0.5 * delta) * m[a];
      o.tj[a] = -(rj - 0.5 * delta) * m[a];
    }
  }

  // A wall contact: c.rp from the wall contact point to the particle,
  // |rp| < R_i; the wall has infinite mass. d_iw and the lever (Rapaport's
  // wall readings) do not enter.
  GRANULAR_HD void wall_lane(const WallContact<Dim>& c, WallForce<Dim>& o) const {
    constexpr int kA = kAngDim<Dim>;
    const Coeff& k = wall[c.ci];
    double r2 = 0.0;
    for (int a = 0; a < Dim; ++a) r2 += c.rp[a] * c.rp[a];
    const double r = std::sqrt(r2);
    double n[Dim], vt[Dim], fs[Dim], wr[kA], wxn[Dim], m[kA];
    for (int a = 0; a < Dim; ++a) n[a] = c.rp[a] / r;
    const double ri = 0.5 * c.di;
    double vn = 0.0;
    for (int a = 0; a < Dim; ++a) vn += c.v[a] * n[a];
    const double damp_n = k.gamma_n / c.inv_mi;
    const double fn = k.kn * (ri - r) - damp_n * vn;
    for (int a = 0; a < kA; ++a) wr[a] = ri * c.w[a];
    spin_cross_c(wr, n, wxn);
    double vt2 = 0.0;
    for (int a = 0; a < Dim; ++a) {
      vt[a] = c.v[a] - vn * n[a] - wxn[a];
      vt2 += vt[a] * vt[a];
    }
    capped_friction_c(vt, vt2, k.xgamma_t * damp_n, k.mu * std::abs(fn), fs);
    moment_c(n, fs, m);
    for (int a = 0; a < Dim; ++a) o.f[a] = fn * n[a] + fs[a];
    for (int a = 0; a < kA; ++a) o.t[a] = -ri * m[a];
  }

  // Set from a scene of Rapaport's particles (scene/law_mapping.hpp's
  // MappingInputs) by the map of docs/model_mapping.md: contact diameters
  // 2^(1/6) d, walls of zero thickness moved in by 2^(1/6) d_w / 2.
  template <class In, int D = Dim, std::enable_if_t<D == 3, int> = 0>
  static MappedLaw<LinearLaw> from_rapaport(const In& in) {
    const auto map = map_rapaport_to_linear(in);  // scene/law_mapping.hpp
    return {map.law, map.diameter_scale, map.wall_inset, 0.0};
  }
};

}  // namespace granular
