// YADE's viscoelastic law, computed as YADE 2023.02a computes it:
//   Ip2_ViscElMat_ViscElMat_ViscElPhys + Law2_ScGeom_ViscElPhys_Basic with
//   ViscElMat(kn, cn, ks = 0, cs, frictionAngle = 0) on Ig2_Sphere_Sphere_ScGeom
//   and Ig2_Facet_Sphere_ScGeom.
// It is the law the YADE cases run (yade_cases/), so that the native engine can
// run exactly what YADE runs: native-with-this-law against YADE isolates
// implementation differences, and this law against the paper's isolates the
// model difference (an uncapped tangential force, a clipped normal force).
//
// Materials (one per species; a facet wall per species): kn, and cn, cs per
// unit mass of the particle (a YADE material per particle with cn = c m_i).
// Pair values mix by YADE's "consecutive connection" rule, where 0 counts as
// absent:
//   mix(a, b) = 1 / (1/a + 1/b),  mix(a, 0) = a,  mix(0, b) = b
//   k_n = mix(kn_i, kn_j),  c_n = mix(cn_i m_i, cn_j m_j),  c_s = mix(cs_i m_i, cs_j m_j)
// (walls: mix(particle value, wall value), the wall's values absolute).
// For particles i, j with radii R_i, R_j, n = (r_i - r_j)/r, delta = R_i + R_j - r > 0,
// the contact point in the middle of the overlap, levers l_i = R_i - delta/2:
//   v_t = v_ij - (v_ij . n) n - (l_i w_i + l_j w_j) x n
//   F_n = max(0, k_n delta - c_n (v_ij . n))            clipped: never attractive
//   F_t = -c_s v_t                                        never capped by Coulomb
//   torque on i: -l_i n x F_t,  on j: -l_j n x F_t
// A facet wall: the same with the wall's side absent (lever l_i = R_i - delta/2,
// the facet's contact point; the wall's velocity at that point in v_iw).
// The Coulomb test of Law2 compares only the elastic shear force (zero for
// ks = 0) with mu |F_n|, so the viscous tangential force is never capped.
#pragma once
#include <array>
#include <cmath>

#include "core/space.hpp"

namespace granular {

template <int Dim>
struct ViscElLaw {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  static constexpr int kSpecies = 3;  // drum: small, big; box: small, big, wall particle

  struct Material {
    double kn = 0.0;           // stiffness (force per overlap); 0 = absent
    double cn_per_mass = 0.0;  // normal damping per unit particle mass
    double cs_per_mass = 0.0;  // tangential damping per unit particle mass
  };
  struct WallMaterial {
    double kn = 0.0, cn = 0.0, cs = 0.0;  // absolute values; 0 = absent
  };

  std::array<Material, kSpecies> mat{};
  std::array<WallMaterial, kSpecies> wall{};  // the facet cylinder species c touches

  // The Coulomb coefficient of the capped law this one was mapped from. The law
  // never uses it; engine/coulomb_census.hpp counts the contacts whose viscous
  // tangential force exceeds mu |F_n|, i.e. where a cap would have bound.
  std::array<double, kSpecies * kSpecies> mu_ref{};
  std::array<double, kSpecies> wall_mu_ref{};
  double coulomb_mu(int ci, int cj) const { return mu_ref[ci * kSpecies + cj]; }
  double wall_coulomb_mu(int ci) const { return wall_mu_ref[ci]; }

  GRANULAR_INLINE static double mix(double a, double b) {
    if (a == 0.0) return b;
    if (b == 0.0) return a;
    return 1.0 / (1.0 / a + 1.0 / b);
  }

  // range = kRangeFactor * (d_i + d_j): the neighbour build tests it in vector
  // lanes in this form (neighbor/range_scan.hpp).
  static constexpr double kRangeFactor = 0.5;
  GRANULAR_INLINE static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  struct PairResult {
    V f;
    A ti;
    A tj;
  };

  GRANULAR_INLINE PairResult pair_force(const V& dr, double r2, double di, double dj, const V& vij, const A& wi,
                                        const A& wj, int ci, int cj, double inv_mi, double inv_mj) const {
    const Material& a = mat[ci];
    const Material& b = mat[cj];
    const double r = std::sqrt(r2);
    const V n = dr / r;
    const double ri = 0.5 * di, rj = 0.5 * dj;
    const double delta = ri + rj - r;
    const double li = ri - 0.5 * delta, lj = rj - 0.5 * delta;
    const double kn = mix(a.kn, b.kn);
    const double cn = mix(a.cn_per_mass / inv_mi, b.cn_per_mass / inv_mj);
    const double cs = mix(a.cs_per_mass / inv_mi, b.cs_per_mass / inv_mj);
    const double vn = vij.dot(n);
    const double fn = std::max(0.0, kn * delta - cn * vn);
    const A wl = li * wi + lj * wj;
    const V vt = vij - vn * n - spin_cross(wl, n);
    const V fs = -cs * vt;
    const A m = moment(n, fs);
    return {fn * n + fs, -li * m, -lj * m};
  }

  struct WallResult {
    V f;
    A t;
  };

  // rp: from the wall contact point to the particle centre, |rp| < R_i.
  GRANULAR_INLINE WallResult wall_force(const V& rp, double di, double /*d_iw*/, const V& viw, const A& wi,
                                        const V& /*lever*/, int ci, double inv_mi) const {
    const Material& a = mat[ci];
    const WallMaterial& w = wall[ci];
    const double r = rp.norm();
    const V n = rp / r;
    const double ri = 0.5 * di;
    const double delta = ri - r;
    const double li = ri - 0.5 * delta;
    const double kn = mix(a.kn, w.kn);
    const double cn = mix(a.cn_per_mass / inv_mi, w.cn);
    const double cs = mix(a.cs_per_mass / inv_mi, w.cs);
    const double vn = viw.dot(n);
    const double fn = std::max(0.0, kn * delta - cn * vn);
    const V vt = viw - vn * n - spin_cross(A(li * wi), n);
    const V fs = -cs * vt;
    return {fn * n + fs, -li * moment(n, fs)};
  }
};

}  // namespace granular
