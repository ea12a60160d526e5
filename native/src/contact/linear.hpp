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

#include "contact/pair_batch.hpp"
#include "contact/wall_batch.hpp"
#include "core/space.hpp"

namespace granular {

template <int Dim>
struct LinearLaw {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
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
  GRANULAR_INLINE static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  struct PairResult {
    V f;
    A ti;
    A tj;
  };

  GRANULAR_INLINE static V friction(const V& vt, const Coeff& c, double damp_n, double fn) {
    const double vrel = vt.norm();
    if (vrel == 0.0) return V::Zero();
    const double fs = std::min(c.xgamma_t * damp_n * vrel, c.mu * std::abs(fn));
    return (-fs / vrel) * vt;
  }

  GRANULAR_INLINE PairResult pair_force(const V& dr, double r2, double di, double dj, const V& vij, const A& wi,
                                        const A& wj, int ci, int cj, double inv_mi, double inv_mj) const {
    const Coeff& c = pair[ci * kSpecies + cj];
    const double r = std::sqrt(r2);
    const V n = dr / r;
    const double ri = 0.5 * di, rj = 0.5 * dj;
    const double delta = ri + rj - r;
    const double meff = 1.0 / (inv_mi + inv_mj);
    const double vn = vij.dot(n);
    const double damp_n = c.gamma_n * meff;
    const double fn = c.kn * delta - damp_n * vn;
    const A wr = ri * wi + rj * wj;
    const V vt = vij - vn * n - spin_cross(wr, n);
    const V fs = friction(vt, c, damp_n, fn);
    const A m = moment(n, fs);
    return {fn * n + fs, -(ri - 0.5 * delta) * m, -(rj - 0.5 * delta) * m};
  }

  // pair_force over a batch of contacts (contact/pair_batch.hpp), the same
  // equations in the same order, lane by lane.
  void pair_force_batch(PairBatch<Dim>& b) const {
    constexpr int kA = PairBatch<Dim>::kAng;
    const int nb = b.n;
#pragma omp simd
    for (int k = 0; k < nb; ++k) {
      const Coeff& c = pair[b.ci[k] * kSpecies + b.cj[k]];
      const double r = std::sqrt(b.r2[k]);
      double n[Dim], vt[Dim], fs[Dim], wr[kA], wxn[Dim], m[kA];
      for (int a = 0; a < Dim; ++a) n[a] = b.dr[a][k] / r;
      const double ri = 0.5 * b.di[k], rj = 0.5 * b.dj[k];
      const double delta = ri + rj - r;
      const double meff = 1.0 / (b.inv_mi[k] + b.inv_mj[k]);
      double vn = 0.0;
      for (int a = 0; a < Dim; ++a) vn += b.v[a][k] * n[a];
      const double damp_n = c.gamma_n * meff;
      const double fn = c.kn * delta - damp_n * vn;
      for (int a = 0; a < kA; ++a) wr[a] = ri * b.wi[a][k] + rj * b.wj[a][k];
      spin_cross_c(wr, n, wxn);
      double vt2 = 0.0;
      for (int a = 0; a < Dim; ++a) {
        vt[a] = b.v[a][k] - vn * n[a] - wxn[a];
        vt2 += vt[a] * vt[a];
      }
      // friction(): F_t = -min(x_t g_n m_eff |v_t|, mu |F_n|) v_t/|v_t|, zero at v_t = 0
      capped_friction_c(vt, vt2, c.xgamma_t * damp_n, c.mu * std::abs(fn), fs);
      moment_c(n, fs, m);
      for (int a = 0; a < Dim; ++a) b.f[a][k] = fn * n[a] + fs[a];
      for (int a = 0; a < kA; ++a) {
        b.ti[a][k] = -(ri - 0.5 * delta) * m[a];
        b.tj[a][k] = -(rj - 0.5 * delta) * m[a];
      }
    }
  }

  struct WallResult {
    V f;
    A t;
  };

  // rp: from the wall contact point to the particle, |rp| < R_i; the wall has
  // infinite mass. d_iw and lever (Rapaport's wall readings) do not enter.
  GRANULAR_INLINE WallResult wall_force(const V& rp, double di, double /*d_iw*/, const V& viw, const A& wi,
                                        const V& /*lever*/, int ci, double inv_mi) const {
    const Coeff& c = wall[ci];
    const double r = rp.norm();
    const V n = rp / r;
    const double ri = 0.5 * di;
    const double vn = viw.dot(n);
    const double damp_n = c.gamma_n / inv_mi;
    const double fn = c.kn * (ri - r) - damp_n * vn;
    const V vt = viw - vn * n - spin_cross(A(ri * wi), n);
    const V fs = friction(vt, c, damp_n, fn);
    return {fn * n + fs, -ri * moment(n, fs)};
  }

  // wall_force over a batch of wall contacts (contact/wall_batch.hpp), the
  // same equations in the same order, lane by lane.
  void wall_force_batch(WallBatch<Dim>& b) const {
    constexpr int kA = WallBatch<Dim>::kAng;
    const int nb = b.n;
#pragma omp simd
    for (int k = 0; k < nb; ++k) {
      const Coeff& c = wall[b.ci[k]];
      double r2 = 0.0;
      for (int a = 0; a < Dim; ++a) r2 += b.rp[a][k] * b.rp[a][k];
      const double r = std::sqrt(r2);
      double n[Dim], vt[Dim], fs[Dim], wr[kA], wxn[Dim], m[kA];
      for (int a = 0; a < Dim; ++a) n[a] = b.rp[a][k] / r;
      const double ri = 0.5 * b.di[k];
      double vn = 0.0;
      for (int a = 0; a < Dim; ++a) vn += b.v[a][k] * n[a];
      const double damp_n = c.gamma_n / b.inv_mi[k];
      const double fn = c.kn * (ri - r) - damp_n * vn;
      for (int a = 0; a < kA; ++a) wr[a] = ri * b.w[a][k];
      spin_cross_c(wr, n, wxn);
      double vt2 = 0.0;
      for (int a = 0; a < Dim; ++a) {
        vt[a] = b.v[a][k] - vn * n[a] - wxn[a];
        vt2 += vt[a] * vt[a];
      }
      capped_friction_c(vt, vt2, c.xgamma_t * damp_n, c.mu * std::abs(fn), fs);  // friction()
      moment_c(n, fs, m);
      for (int a = 0; a < Dim; ++a) b.f[a][k] = fn * n[a] + fs[a];
      for (int a = 0; a < kA; ++a) b.t[a][k] = -ri * m[a];
    }
  }
};

}  // namespace granular
