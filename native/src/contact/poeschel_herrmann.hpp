// Linear spring-dashpot contact with viscous tangential friction capped by
// Coulomb, after Cundall and Strack, as used by T. Poeschel and H. J. Herrmann,
// Europhys. Lett. (1995) ("Size segregation and convection"), Eqs. (1)-(6):
//
//   F_ij = F^N n + F^S t,  n = (r_i - r_j)/|r_i - r_j|,  t = [[0,-1],[1,0]] n    Eq. (1)
//   F^N  = Y (R_i + R_j - |r_i - r_j|) + gamma_N m_eff (damping term)           Eq. (2)
//   F^S  = -sign(v_rel) min(gamma_S m_eff |v_rel|, mu |F^N|)                    Eq. (3)
//   v_rel = tangential relative velocity at the contact point                   Eq. (4)
//   m_eff = m_i m_j / (m_i + m_j)                                                Eq. (5)
//   torques from F^S at the contact points, lever R_i and R_j                    Eq. (6)
//
// Readings (docs/shaken_box.md):
// - Damping (Eq. (2)): the paper prints gamma_N m_eff |r_i' - r_j'|, which is
//   never dissipative on approach. Kinematic reading (default): the normal
//   component of the relative velocity, F^N = Y xi - gamma_N m_eff (v_ij . n),
//   the Cundall-Strack dashpot (LAMMPS gran/hooke). The literal form is the
//   template option Damping::literal (scene key contact.damping = "literal").
// - Signs in Eqs. (3), (4), (6): the paper's printed signs fix one orientation
//   convention; here v_rel is the velocity of i's contact point relative to j's
//   along t, v_rel = (v_i - v_j) . t - R_i w_i - R_j w_j (w counter-clockwise),
//   the friction opposes it, and each torque is (contact point - centre) x force,
//   i.e. -R_i F^S on i and -R_j F^S on j, so friction never feeds energy in.
// - No clipping of an attractive F^N (as in the paper and LAMMPS gran/hooke);
//   the cap uses |F^N|.
#pragma once
#include <algorithm>
#include <cmath>

#include "contact/lane.hpp"
#include "contact/law_paths.hpp"

namespace granular {

// The reading of Eq. (2)'s damping term (scene key contact.damping).
enum class Damping {
  normal,   // the normal component of the relative velocity (default)
  literal,  // |v_ij|, as printed
};

template <int Dim, Damping D = Damping::normal>
struct PoeschelHerrmannLaw : LawPaths<PoeschelHerrmannLaw<Dim, D>, Dim> {
  static constexpr const char* kName = "poeschel_herrmann";  // contact.law
  static constexpr Damping kDamping = D;                     // contact.damping
  static constexpr bool kInDim = Dim == 2;                   // written for disks
  // One contact at a time: the shaken box's results are those of that order
  // of summation (contact/pair_batch.hpp).
  static constexpr bool kVectorised = false;

  double young = 3e6;    // Y, g/s^2 (a spring constant per unit depth)
  double gamma_n = 100;  // gamma_N, 1/s
  double gamma_s = 1;    // gamma_S, 1/s
  double mu = 0.5;       // Coulomb coefficient
  static constexpr int kSpecies = 3;  // grain, big disk, wall particle (integrate/motion.hpp)

  // The Coulomb coefficient of a contact (engine/coulomb_census.hpp); walls are particles.
  double coulomb_mu(int, int) const { return mu; }
  double wall_coulomb_mu(int) const { return mu; }

  // Contact when |r_i - r_j| < R_i + R_j.
  // range = kRangeFactor * (d_i + d_j): the neighbour build tests it in vector
  // lanes in this form (neighbor/range_scan.hpp).
  static constexpr double kRangeFactor = 0.5;
  GRANULAR_HD static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  // A pair contact (contact/lane.hpp): Eqs. (1)-(6). Walls are particles.
  GRANULAR_HD void pair_lane(const PairContact<2>& c, PairForce<2>& o) const {
    const double r = std::sqrt(c.r2);
    const double n[2] = {c.dr[0] / r, c.dr[1] / r};
    const double t[2] = {-n[1], n[0]};                 // Eq. (1)
    const double m_eff = 1.0 / (c.inv_mi + c.inv_mj);  // Eq. (5); a wall particle of infinite mass has inv_m = 0
    const double ri = 0.5 * c.di, rj = 0.5 * c.dj;
    double fn = young * (ri + rj - r);  // Eq. (2), elastic part
    if constexpr (D == Damping::literal)
      fn += gamma_n * m_eff * std::sqrt(lane_dot(c.v, c.v));  // Eq. (2) as printed
    else
      fn -= gamma_n * m_eff * lane_dot(c.v, n);  // Eq. (2), normal relative velocity
    const double vrel = lane_dot(c.v, t) - ri * c.wi[0] - rj * c.wj[0];  // Eq. (4)
    const double cap = mu * std::abs(fn);
    const double fs = -std::copysign(std::min(gamma_s * m_eff * std::abs(vrel), cap), vrel);  // Eq. (3)
    for (int a = 0; a < 2; ++a) o.f[a] = fn * n[a] + fs * t[a];
    o.ti[0] = -ri * fs;  // Eq. (6)
    o.tj[0] = -rj * fs;
  }

  // Set from the shaken box's scene (scene/box_scene.hpp): Y, gamma_N,
  // gamma_S, mu as given.
  template <class Scene>
  static PoeschelHerrmannLaw from_box(const Scene& s) {
    PoeschelHerrmannLaw law;
    law.young = s.young;
    law.gamma_n = s.gamma_n;
    law.gamma_s = s.gamma_s;
    law.mu = s.mu;
    return law;
  }
};

}  // namespace granular
