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
#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>

#include "contact/lane.hpp"
#include "contact/law_paths.hpp"

namespace granular {

template <int Dim>
struct ViscElLaw : LawPaths<ViscElLaw<Dim>, Dim> {
  static constexpr const char* kName = "viscel";  // contact.law
  static constexpr bool kInDim = true;            // written for 2D and 3D
  // One contact at a time: the results compared with YADE are those of that
  // order of summation (contact/pair_batch.hpp).
  static constexpr bool kVectorised = false;
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

  GRANULAR_HD static double mix(double a, double b) {
    if (a == 0.0) return b;
    if (b == 0.0) return a;
    return 1.0 / (1.0 / a + 1.0 / b);
  }

  // range = kRangeFactor * (d_i + d_j): the neighbour build tests it in vector
  // lanes in this form (neighbor/range_scan.hpp).
  static constexpr double kRangeFactor = 0.5;
  GRANULAR_HD static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  // A pair contact (contact/lane.hpp).
  GRANULAR_HD void pair_lane(const PairContact<Dim>& c, PairForce<Dim>& o) const {
    constexpr int kA = kAngDim<Dim>;
    const Material& a = mat[c.ci];
    const Material& b = mat[c.cj];
    const double r = std::sqrt(c.r2);
    double n[Dim], vt[Dim], fs[Dim], wl[kA], wxn[Dim], m[kA];
    for (int k = 0; k < Dim; ++k) n[k] = c.dr[k] / r;
    const double ri = 0.5 * c.di, rj = 0.5 * c.dj;
    const double delta = ri + rj - r;
    const double li = ri - 0.5 * delta, lj = rj - 0.5 * delta;
    const double kn = mix(a.kn, b.kn);
    const double cn = mix(a.cn_per_mass / c.inv_mi, b.cn_per_mass / c.inv_mj);
    const double cs = mix(a.cs_per_mass / c.inv_mi, b.cs_per_mass / c.inv_mj);
    const double vn = lane_dot(c.v, n);
    const double fn = std::max(0.0, kn * delta - cn * vn);  // clipped: never attractive
    for (int k = 0; k < kA; ++k) wl[k] = li * c.wi[k] + lj * c.wj[k];
    spin_cross_c(wl, n, wxn);
    for (int k = 0; k < Dim; ++k) {
      vt[k] = c.v[k] - vn * n[k] - wxn[k];
      fs[k] = -cs * vt[k];  // never capped by Coulomb
    }
    moment_c(n, fs, m);
    for (int k = 0; k < Dim; ++k) o.f[k] = fn * n[k] + fs[k];
    for (int k = 0; k < kA; ++k) {
      o.ti[k] = -li * m[k];
      o.tj[k] = -lj * m[k];
    }
  }

  // A facet wall: c.rp from the wall contact point to the particle centre,
  // |rp| < R_i; d_iw and the lever (Rapaport's wall readings) do not enter.
  GRANULAR_HD void wall_lane(const WallContact<Dim>& c, WallForce<Dim>& o) const {
    constexpr int kA = kAngDim<Dim>;
    const Material& a = mat[c.ci];
    const WallMaterial& w = wall[c.ci];
    const double r = std::sqrt(lane_dot(c.rp, c.rp));
    double n[Dim], vt[Dim], fs[Dim], wl[kA], wxn[Dim], m[kA];
    for (int k = 0; k < Dim; ++k) n[k] = c.rp[k] / r;
    const double ri = 0.5 * c.di;
    const double delta = ri - r;
    const double li = ri - 0.5 * delta;
    const double kn = mix(a.kn, w.kn);
    const double cn = mix(a.cn_per_mass / c.inv_mi, w.cn);
    const double cs = mix(a.cs_per_mass / c.inv_mi, w.cs);
    const double vn = lane_dot(c.v, n);
    const double fn = std::max(0.0, kn * delta - cn * vn);
    for (int k = 0; k < kA; ++k) wl[k] = li * c.w[k];
    spin_cross_c(wl, n, wxn);
    for (int k = 0; k < Dim; ++k) {
      vt[k] = c.v[k] - vn * n[k] - wxn[k];
      fs[k] = -cs * vt[k];
    }
    moment_c(n, fs, m);
    for (int k = 0; k < Dim; ++k) o.f[k] = fn * n[k] + fs[k];
    for (int k = 0; k < kA; ++k) o.t[k] = -li * m[k];
  }

  // Set from a scene of Rapaport's particles (scene/law_mapping.hpp's
  // MappingInputs): the linear law's map, then YADE's materials nearest to
  // it, with the linear law's contact geometry.
  template <class In, int D = Dim, std::enable_if_t<D == 3, int> = 0>
  static MappedLaw<ViscElLaw> from_rapaport(const In& in) {
    const auto map = map_rapaport_to_linear(in);  // scene/law_mapping.hpp
    return {map_linear_to_viscel(in, map).law, map.diameter_scale, map.wall_inset, 0.0};
  }

  // Set from the shaken box's scene (scene/box_scene.hpp): one material per
  // species, coefficients per unit mass: harmonic mixing gives a pair
  // k_n = Y, c_n = gamma_N m_eff, c_s = gamma_S m_eff for any two masses (and
  // m_eff = m_i against an infinitely heavy wall particle), i.e. Eqs. (1)-(6)
  // of Poeschel and Herrmann with the normal force clipped at zero and no
  // Coulomb cap, as yade_cases/box_case.py sets up YADE (one ViscElMat per
  // particle).
  template <class Scene, int D = Dim, std::enable_if_t<D == 2, int> = 0>
  static ViscElLaw from_box(const Scene& s) {
    ViscElLaw law;
    for (auto& m : law.mat) m = {2.0 * s.young, s.gamma_n, s.gamma_s};
    for (int a = 0; a < kSpecies; ++a)
      for (int b = 0; b < kSpecies; ++b) law.mu_ref[a * kSpecies + b] = s.mu;
    return law;
  }
};

}  // namespace granular
