// Rapaport's soft-sphere granular contact law.
// D. C. Rapaport, Phys. Rev. E 65, 061306 (2002), Sec. III:
//
//   f_v = 48/r [ (d_ij/r)^12 - 1/2 (d_ij/r)^6 ] r^      for r < 2^(1/6) d_ij     Eq. (1)
//   f_d = -gamma_n (r^ . v_ij) r^                                                Eq. (2)
//   f_n = f_v + f_d
//   v_s = v_ij - (r^ . v_ij) r^ - (d_i w_i + d_j w_j)/(d_i + d_j) x r_ij           Eq. (3)
//   f_s = -min(gamma_s^{ci cj} |v_s|, mu^{ci cj} |f_n|) v^_s                      Eq. (4)
//
// with r_ij = r_i - r_j, d_ij = (d_i + d_j)/2, gamma_n not mass weighted. The
// paper adds f_n + f_s to m_i a_i, subtracts it from m_j a_j, and subtracts
// r^ x f_s / kappa from both m_i d_i alpha_i and m_j d_j alpha_j. With
// I = kappa m d^2 / 2 (= 0.1 m d^2 = 2/5 m R^2 for kappa = 0.2) that is the torque
// tau = -(d/2) r^ x f_s on each particle, which is what we accumulate; the
// integrator divides by I. Walls (Eq. (5)) use the same normal and sliding parts.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>

#include "contact/pair_batch.hpp"
#include "contact/wall_batch.hpp"
#include "core/space.hpp"

namespace granular {

template <int Dim>
struct RapaportLaw {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  static constexpr double kCutFactor = 1.12246204830937298143;  // 2^(1/6), Eq. (1)
  static constexpr int kSpecies = 2;

  struct Friction {
    double gamma_s = 0.0;  // sliding friction coefficient gamma_s
    double mu = 0.0;       // static friction coefficient mu: cap mu |f_n|
  };

  double gamma_n = 5.0;                            // Eq. (2)
  std::array<Friction, kSpecies * kSpecies> pair{};  // [c_i * kSpecies + c_j]
  std::array<Friction, kSpecies> wall{};            // [c_i]

  // The Coulomb coefficient of a contact (engine/coulomb_census.hpp).
  double coulomb_mu(int ci, int cj) const { return pair[ci * kSpecies + cj].mu; }
  double wall_coulomb_mu(int ci) const { return wall[ci].mu; }

  // Interaction range for particles (or particle and wall) of diameters d_i, d_j.
  // range = kRangeFactor * (d_i + d_j): the neighbour build tests it in vector
  // lanes in this form (neighbor/range_scan.hpp).
  static constexpr double kRangeFactor = kCutFactor * 0.5;
  GRANULAR_INLINE static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  // Eq. (1) + Eq. (2): the signed magnitude of f_n along r^ (positive pushes apart).
  GRANULAR_INLINE static double normal(double inv_r, double dij, double vn, double gamma_n) {
    const double s2 = dij * dij * inv_r * inv_r;
    const double s6 = s2 * s2 * s2;
    return 48.0 * inv_r * s6 * (s6 - 0.5) - gamma_n * vn;
  }

  // Eq. (4)/(5): f_s = -min(gamma_s |v_s|, mu |f_n|) v^_s.
  GRANULAR_INLINE static V sliding(const V& vs, const Friction& fr, double fn) {
    const double vs2 = vs.squaredNorm();
    if (vs2 == 0.0) return V::Zero();
    const double vabs = std::sqrt(vs2);
    const double mag = std::min(fr.gamma_s * vabs, fr.mu * std::abs(fn));
    return (-mag / vabs) * vs;
  }

  struct PairResult {
    V f;   // force on i (j gets -f)
    A ti;  // torque on i
    A tj;  // torque on j
  };

  // dr = r_i - r_j after minimum image, r2 = |dr|^2 < range(d_i, d_j)^2.
  // (Masses do not enter Rapaport's forces: the inverse masses are unused.)
  GRANULAR_INLINE PairResult pair_force(const V& dr, double r2, double di, double dj, const V& vij, const A& wi,
                                        const A& wj, int ci, int cj, double /*inv_mi*/, double /*inv_mj*/) const {
    const double inv_r = 1.0 / std::sqrt(r2);
    const V n = dr * inv_r;
    const double vn = n.dot(vij);
    const double fn = normal(inv_r, 0.5 * (di + dj), vn, gamma_n);  // Eqs. (1), (2)
    const A wbar = (di * wi + dj * wj) / (di + dj);
    const V vs = vij - vn * n - spin_cross(wbar, dr);  // Eq. (3)
    const V fs = sliding(vs, pair[ci * kSpecies + cj], fn);  // Eq. (4)
    const A m = moment(n, fs);
    return {fn * n + fs, -0.5 * di * m, -0.5 * dj * m};
  }

  // pair_force over a batch of contacts (contact/pair_batch.hpp): Eqs. (1)-(4)
  // in the same order, lane by lane.
  void pair_force_batch(PairBatch<Dim>& b) const {
    constexpr int kA = PairBatch<Dim>::kAng;
    const int nb = b.n;
#pragma omp simd
    for (int k = 0; k < nb; ++k) {
      const Friction& fr = pair[b.ci[k] * kSpecies + b.cj[k]];
      const double inv_r = 1.0 / std::sqrt(b.r2[k]);
      const double di = b.di[k], dj = b.dj[k];
      double n[Dim], dr[Dim], vs[Dim], fs[Dim], wbar[kA], wxr[Dim], m[kA];
      for (int a = 0; a < Dim; ++a) {
        dr[a] = b.dr[a][k];
        n[a] = dr[a] * inv_r;
      }
      double vn = 0.0;
      for (int a = 0; a < Dim; ++a) vn += n[a] * b.v[a][k];
      const double fn = normal(inv_r, 0.5 * (di + dj), vn, gamma_n);  // Eqs. (1), (2)
      for (int a = 0; a < kA; ++a) wbar[a] = (di * b.wi[a][k] + dj * b.wj[a][k]) / (di + dj);
      spin_cross_c(wbar, dr, wxr);
      double vs2 = 0.0;
      for (int a = 0; a < Dim; ++a) {
        vs[a] = b.v[a][k] - vn * n[a] - wxr[a];  // Eq. (3)
        vs2 += vs[a] * vs[a];
      }
      capped_friction_c(vs, vs2, fr.gamma_s, fr.mu * std::abs(fn), fs);  // sliding(), Eq. (4)
      moment_c(n, fs, m);
      for (int a = 0; a < Dim; ++a) b.f[a][k] = fn * n[a] + fs[a];
      for (int a = 0; a < kA; ++a) {
        b.ti[a][k] = -0.5 * di * m[a];
        b.tj[a][k] = -0.5 * dj * m[a];
      }
    }
  }

  struct WallResult {
    V f;
    A t;
  };

  // Particle-wall contact (Sec. III, Eq. (5)). rp = r'_iw points from the wall
  // contact point to the particle, |rp| < range(d_i, d_w); d_iw = (d_i + d_w)/2;
  // viw = v_i - Omega s; lever multiplies w_i in the sliding velocity
  // (the paper writes w_i x r'_iw, i.e. lever = r'_iw).
  GRANULAR_INLINE WallResult wall_force(const V& rp, double di, double d_iw, const V& viw, const A& wi, const V& lever,
                        int ci, double /*inv_mi*/ = 0.0) const {
    const double inv_r = 1.0 / rp.norm();
    const V n = rp * inv_r;
    const double vn = n.dot(viw);
    const double fn = normal(inv_r, d_iw, vn, gamma_n);  // Eqs. (1), (2) with d_iw
    const V vs = viw - vn * n - spin_cross(wi, lever);   // v^s_iw, Sec. III
    const V fs = sliding(vs, wall[ci], fn);              // Eq. (5)
    return {fn * n + fs, -0.5 * di * moment(n, fs)};
  }

  // wall_force over a batch of wall contacts (contact/wall_batch.hpp):
  // Eqs. (1), (2), (5) in the same order, lane by lane.
  void wall_force_batch(WallBatch<Dim>& b) const {
    constexpr int kA = WallBatch<Dim>::kAng;
    const int nb = b.n;
#pragma omp simd
    for (int k = 0; k < nb; ++k) {
      const Friction& fr = wall[b.ci[k]];
      double r2 = 0.0;
      for (int a = 0; a < Dim; ++a) r2 += b.rp[a][k] * b.rp[a][k];
      const double inv_r = 1.0 / std::sqrt(r2);
      double n[Dim], lv[Dim], vs[Dim], fs[Dim], wi[kA], wxl[Dim], m[kA];
      for (int a = 0; a < Dim; ++a) {
        n[a] = b.rp[a][k] * inv_r;
        lv[a] = b.lever[a][k];
      }
      for (int a = 0; a < kA; ++a) wi[a] = b.w[a][k];
      double vn = 0.0;
      for (int a = 0; a < Dim; ++a) vn += n[a] * b.v[a][k];
      const double fn = normal(inv_r, b.d_iw[k], vn, gamma_n);  // Eqs. (1), (2) with d_iw
      spin_cross_c(wi, lv, wxl);
      double vs2 = 0.0;
      for (int a = 0; a < Dim; ++a) {
        vs[a] = b.v[a][k] - vn * n[a] - wxl[a];  // v^s_iw, Sec. III
        vs2 += vs[a] * vs[a];
      }
      capped_friction_c(vs, vs2, fr.gamma_s, fr.mu * std::abs(fn), fs);  // sliding(), Eq. (5)
      moment_c(n, fs, m);
      for (int a = 0; a < Dim; ++a) b.f[a][k] = fn * n[a] + fs[a];
      for (int a = 0; a < kA; ++a) b.t[a][k] = -0.5 * b.di[k] * m[a];
    }
  }

  // Potential of Eq. (1), shifted to zero at the cutoff; for energy checks only.
  static double potential(double r, double dij) {
    if (r >= kCutFactor * dij) return 0.0;
    const double s6 = std::pow(dij / r, 6);
    return 4.0 * (s6 * s6 - s6) + 1.0;
  }

  // Paper's rules (Sec. III): gamma_s^{bs} = min(gamma_s^{bb}, gamma_s^{ss}); the mu
  // of each pair (bb/ss and bw/sw) is in the ratio of the gamma_s values, the
  // larger being mu_max. For the big-small pair we take mu^{bs} = min(mu^{bb}, mu^{ss}),
  // the same rule as for gamma_s. Species: 0 = small, 1 = big.
  static RapaportLaw from_paper(double gamma_n, double g_bb, double g_ss, double g_bw, double g_sw,
                                double mu_max) {
    RapaportLaw law;
    law.gamma_n = gamma_n;
    const double gpp = std::max(g_bb, g_ss), gpw = std::max(g_bw, g_sw);
    const double mu_bb = gpp > 0 ? mu_max * g_bb / gpp : mu_max;
    const double mu_ss = gpp > 0 ? mu_max * g_ss / gpp : mu_max;
    const Friction ss{g_ss, mu_ss}, bb{g_bb, mu_bb}, bs{std::min(g_bb, g_ss), std::min(mu_bb, mu_ss)};
    law.pair = {ss, bs, bs, bb};
    law.wall = {Friction{g_sw, gpw > 0 ? mu_max * g_sw / gpw : mu_max},
                Friction{g_bw, gpw > 0 ? mu_max * g_bw / gpw : mu_max}};
    return law;
  }
};

}  // namespace granular
