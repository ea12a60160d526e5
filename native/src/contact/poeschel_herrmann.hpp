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
//   template option Literal = true.
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

#include "core/space.hpp"

namespace granular {

template <int Dim, bool Literal = false>
struct PoeschelHerrmannLaw {
  static_assert(Dim == 2, "the Poeschel-Herrmann law is written for disks");
  using V = Vec<2>;
  using A = Ang<2>;

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
  GRANULAR_INLINE static double range(double di, double dj) { return kRangeFactor * (di + dj); }

  struct PairResult {
    V f;   // force on i (j gets -f)
    A ti;  // torque on i
    A tj;  // torque on j
  };

  GRANULAR_INLINE PairResult pair_force(const V& dr, double r2, double di, double dj, const V& vij, const A& wi,
                                        const A& wj, int /*ci*/, int /*cj*/, double inv_mi, double inv_mj) const {
    const double r = std::sqrt(r2);
    const V n = dr / r;
    const V t(-n.y(), n.x());
    const double m_eff = 1.0 / (inv_mi + inv_mj);  // Eq. (5); a wall particle of infinite mass has inv_m = 0
    const double ri = 0.5 * di, rj = 0.5 * dj;
    double fn = young * (ri + rj - r);  // Eq. (2), elastic part
    if constexpr (Literal)
      fn += gamma_n * m_eff * vij.norm();  // Eq. (2) as printed
    else
      fn -= gamma_n * m_eff * vij.dot(n);  // Eq. (2), normal relative velocity
    const double vrel = vij.dot(t) - ri * wi[0] - rj * wj[0];  // Eq. (4)
    const double cap = mu * std::abs(fn);
    const double fs = -std::copysign(std::min(gamma_s * m_eff * std::abs(vrel), cap), vrel);  // Eq. (3)
    A ti, tj;
    ti[0] = -ri * fs;  // Eq. (6)
    tj[0] = -rj * fs;
    return {fn * n + fs * t, ti, tj};
  }
};

}  // namespace granular
