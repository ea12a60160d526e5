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
#include <type_traits>

#include "contact/lane.hpp"
#include "contact/law_paths.hpp"

namespace granular {

template <int Dim>
struct RapaportLaw : LawPaths<RapaportLaw<Dim>, Dim> {
  static constexpr const char* kName = "rapaport";  // contact.law
  static constexpr bool kInDim = true;              // written for 2D and 3D
  static constexpr bool kVectorised = true;         // pairs and walls in SIMD batches
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
  GRANULAR_HD static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  // Eq. (1) + Eq. (2): the signed magnitude of f_n along r^ (positive pushes apart).
  GRANULAR_HD static double normal(double inv_r, double dij, double vn, double gamma_n) {
    const double s2 = dij * dij * inv_r * inv_r;
    const double s6 = s2 * s2 * s2;
    return 48.0 * inv_r * s6 * (s6 - 0.5) - gamma_n * vn;
  }

  // A pair contact (contact/lane.hpp): Eqs. (1)-(4).
  GRANULAR_HD void pair_lane(const PairContact<Dim>& c, PairForce<Dim>& o) const {
    constexpr int kA = kAngDim<Dim>;
    const Friction& fr = pair[c.ci * kSpecies + c.cj];
    const double inv_r = 1.0 / std::sqrt(c.r2);
    double dr[Dim], n[Dim], vs[Dim], fs[Dim], wbar[kA], wxr[Dim], m[kA];
    for (int a = 0; a < Dim; ++a) {
      dr[a] = c.dr[a];  // a local copy: an array of the contact passed on by reference keeps GCC's SIMD loop scalar
      n[a] = dr[a] * inv_r;
    }
    double vn = 0.0;
    for (int a = 0; a < Dim; ++a) vn += n[a] * c.v[a];
    const double fn = normal(inv_r, 0.5 * (c.di + c.dj), vn, gamma_n);  // Eqs. (1), (2)
    for (int a = 0; a < kA; ++a) wbar[a] = (c.di * c.wi[a] + c.dj * c.wj[a]) / (c.di + c.dj);
    spin_cross_c(wbar, dr, wxr);
    double vs2 = 0.0;
    for (int a = 0; a < Dim; ++a) {
      vs[a] = c.v[a] - vn * n[a] - wxr[a];  // Eq. (3)
      vs2 += vs[a] * vs[a];
    }
    capped_friction_c(vs, vs2, fr.gamma_s, fr.mu * std::abs(fn), fs);  // Eq. (4)
    moment_c(n, fs, m);
    for (int a = 0; a < Dim; ++a) o.f[a] = fn * n[a] + fs[a];
    for (int a = 0; a < kA; ++a) {
      o.ti[a] = -0.5 * c.di * m[a];
      o.tj[a] = -0.5 * c.dj * m[a];
    }
  }

  // A particle-wall contact (Sec. III, Eq. (5)): r'_iw = c.rp, |r'_iw| <
  // range(d_i, d_w), d_iw = (d_i + d_w)/2, v_iw = v_i - Omega s; c.lever
  // multiplies w_i in the sliding velocity (the paper writes w_i x r'_iw,
  // i.e. lever = r'_iw).
  GRANULAR_HD void wall_lane(const WallContact<Dim>& c, WallForce<Dim>& o) const {
    constexpr int kA = kAngDim<Dim>;
    const Friction& fr = wall[c.ci];
    double r2 = 0.0;
    for (int a = 0; a < Dim; ++a) r2 += c.rp[a] * c.rp[a];
    const double inv_r = 1.0 / std::sqrt(r2);
    double n[Dim], lv[Dim], wi[kA], vs[Dim], fs[Dim], wxl[Dim], m[kA];
    for (int a = 0; a < Dim; ++a) {
      n[a] = c.rp[a] * inv_r;
      lv[a] = c.lever[a];  // local copies, as in pair_lane
    }
    for (int a = 0; a < kA; ++a) wi[a] = c.w[a];
    double vn = 0.0;
    for (int a = 0; a < Dim; ++a) vn += n[a] * c.v[a];
    const double fn = normal(inv_r, c.d_iw, vn, gamma_n);  // Eqs. (1), (2) with d_iw
    spin_cross_c(wi, lv, wxl);
    double vs2 = 0.0;
    for (int a = 0; a < Dim; ++a) {
      vs[a] = c.v[a] - vn * n[a] - wxl[a];  // v^s_iw, Sec. III
      vs2 += vs[a] * vs[a];
    }
    capped_friction_c(vs, vs2, fr.gamma_s, fr.mu * std::abs(fn), fs);  // Eq. (5)
    moment_c(n, fs, m);
    for (int a = 0; a < Dim; ++a) o.f[a] = fn * n[a] + fs[a];
    for (int a = 0; a < kA; ++a) o.t[a] = -0.5 * c.di * m[a];
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

  // Set from a scene of Rapaport's particles (the drum, the particles scene:
  // scene/law_mapping.hpp's MappingInputs): the paper's own parameters, the
  // walls' diameter d_w as the scene gives it.
  template <class In, int D = Dim, std::enable_if_t<D == 3, int> = 0>
  static MappedLaw<RapaportLaw> from_rapaport(const In& in) {
    return {in.rapaport(), 1.0, 0.0, in.wall_diameter};
  }
};

}  // namespace granular
