// Gear's predictor-corrector of 5th order (six values) for second-order
// equations, the integrator of Poeschel and Herrmann (1995); C. W. Gear,
// Numerical Initial Value Problems in Ordinary Differential Equations (1971);
// M. P. Allen and D. J. Tildesley, Computer Simulation of Liquids, App. E.
//
// State per particle: scaled derivatives r_k = dt^k / k! d^k r / dt^k, k = 0..5
// (r_0 = x, r_1 = v dt in the store; r_2..r_5 in aux columns), and the same for
// the rotation angle phi (phi_1 = w dt; phi_0, phi_2..phi_5 in aux columns).
//   predict:  r_k <- sum_{j>=k} C(j,k) r_j          (Taylor / Pascal matrix)
//   forces at the predicted positions and velocities
//   correct:  D = a dt^2/2 - r_2;  r_k <- r_k + c_k D
// c = (3/20, 251/360, 1, 11/18, 1/6, 1/60): Gear's coefficients for forces that
// depend on velocities (3/20 in place of 3/16 for position-only forces).
// Wall particles (Motion != NoMotion) are placed, not integrated.
#pragma once
#include <cstddef>
#include <vector>

#include "core/box.hpp"
#include "core/particles.hpp"
#include "integrate/drift_stats.hpp"
#include "integrate/motion.hpp"

namespace granular {

template <int Dim, class Motion = NoMotion>
struct Gear5 {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  using DriftStats = granular::DriftStats;
  static constexpr double kC0 = 3.0 / 20.0, kC1 = 251.0 / 360.0, kC3 = 11.0 / 18.0, kC4 = 1.0 / 6.0,
                          kC5 = 1.0 / 60.0;
  double dt = 5e-5;
  V gravity = V::Zero();
  Motion motion{};
  // Cost per particle and step (predictor and corrector) in listed pairs,
  // for the threads' blocks (neighbor/neighbor_list.hpp): 20 ns in the box.
  static constexpr unsigned kWeight = 10;
  double c0 = kC0;  // 3/16 for position-only forces (tests of the design order)

  // Aux columns: V: r2, r3, r4, r5; A: phi0, phi2, phi3, phi4, phi5. Call after
  // the forces at t = 0 are known: r2 starts from them, higher terms at zero.
  void start(ParticleStore<Dim>& p) const {
    const std::size_t n = p.size();
    p.aux_v.assign(4, std::vector<V>(n, V::Zero()));
    p.aux_a.assign(5, std::vector<A>(n, A::Zero()));
    const double h2 = 0.5 * dt * dt;
    for (std::size_t i = 0; i < n; ++i) {
      p.aux_v[0][i] = h2 * (p.f[i] * p.inv_m[i] + gravity);
      p.aux_a[1][i] = (h2 * p.inv_i[i]) * p.tq[i];
    }
  }

  // Named views of the aux columns (see start()).
  struct Columns {
    std::vector<V>&r2, &r3, &r4, &r5;
    std::vector<A>&q0, &q2, &q3, &q4, &q5;
    explicit Columns(ParticleStore<Dim>& p)
        : r2(p.aux_v[0]), r3(p.aux_v[1]), r4(p.aux_v[2]), r5(p.aux_v[3]), q0(p.aux_a[0]), q2(p.aux_a[1]),
          q3(p.aux_a[2]), q4(p.aux_a[3]), q5(p.aux_a[4]) {}
  };

  DriftStats first_half(ParticleStore<Dim>& p, const Box<Dim>& box, const std::vector<V>& x_ref, std::size_t lo,
                        std::size_t hi, double t_next, const DriftStats& seed = DriftStats()) const {
    // A local, returned as a copy (drift_stats.hpp: kept in registers).
    DriftStats st = seed;
    const auto pose = pose_at(motion, t_next);
    auto [r2, r3, r4, r5, q0, q2, q3, q4, q5] = Columns(p);
    for (std::size_t i = lo; i < hi; ++i) {
      if (place_if_wall(motion, pose, p, i, box, x_ref[i], st)) continue;
      const V r1 = dt * p.v[i];
      const V step = r1 + r2[i] + r3[i] + r4[i] + r5[i];
      V x = p.x[i] + step;  // a copy: see leapfrog.hpp
      box.wrap(x);
      p.x[i] = x;
      p.v[i] = (r1 + 2.0 * r2[i] + 3.0 * r3[i] + 4.0 * r4[i] + 5.0 * r5[i]) / dt;
      r2[i] += 3.0 * r3[i] + 6.0 * r4[i] + 10.0 * r5[i];
      r3[i] += 4.0 * r4[i] + 10.0 * r5[i];
      r4[i] += 5.0 * r5[i];
      const A q1 = dt * p.w[i];
      q0[i] += q1 + q2[i] + q3[i] + q4[i] + q5[i];
      p.w[i] = (q1 + 2.0 * q2[i] + 3.0 * q3[i] + 4.0 * q4[i] + 5.0 * q5[i]) / dt;
      q2[i] += 3.0 * q3[i] + 6.0 * q4[i] + 10.0 * q5[i];
      q3[i] += 4.0 * q4[i] + 10.0 * q5[i];
      q4[i] += 5.0 * q5[i];
      st.add(box, i, step.squaredNorm(), x, x_ref[i]);
    }
    return DriftStats(st);
  }

  void second_half(ParticleStore<Dim>& p, const Box<Dim>& box, std::size_t lo, std::size_t hi) const {
    const double h2 = 0.5 * dt * dt;
    auto [r2, r3, r4, r5, q0, q2, q3, q4, q5] = Columns(p);
    for (std::size_t i = lo; i < hi; ++i) {
      if constexpr (kHasMotion<Motion>)
        if (p.species[i] == kWallSpecies) continue;
      const V d = h2 * (p.f[i] * p.inv_m[i] + gravity) - r2[i];
      p.x[i] += c0 * d;
      box.wrap(p.x[i]);
      p.v[i] += (kC1 / dt) * d;
      r2[i] += d;
      r3[i] += kC3 * d;
      r4[i] += kC4 * d;
      r5[i] += kC5 * d;
      const A e = (h2 * p.inv_i[i]) * p.tq[i] - q2[i];
      q0[i] += c0 * e;
      p.w[i] += (kC1 / dt) * e;
      q2[i] += e;
      q3[i] += kC3 * e;
      q4[i] += kC4 * e;
      q5[i] += kC5 * e;
    }
  }
};

}  // namespace granular
