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
// Wall particles (Motion != NoMotion) are placed, not integrated. Between two
// steps the engine runs the corrector and the next predictor as one pass
// (second_then_first): the same arithmetic, each column touched once.
#pragma once
#include <cstddef>
#include <vector>

#include "contact/lane.hpp"  // GRANULAR_HD
#include "core/domain.hpp"
#include "core/particles.hpp"
#include "integrate/drift_stats.hpp"
#include "integrate/motion.hpp"

namespace granular {

// Which of Gear's stages one pass over the particles runs: the predictor,
// the corrector, or the corrector of one step and the predictor of the next.
enum class GearPass { predict, correct, correct_then_predict };

// Gear's coefficients for forces that depend on velocities (c_2 = 1).
inline constexpr double kGearC0 = 3.0 / 20.0, kGearC1 = 251.0 / 360.0, kGearC3 = 11.0 / 18.0, kGearC4 = 1.0 / 6.0,
                        kGearC5 = 1.0 / 60.0;

// The predictor (the Pascal matrix above): x = r_0, v the velocity
// (r_1 = dt v), r2..r5 the scaled derivatives; returns the step
// r_1 + r_2 + ... + r_5. An angle takes the same, with phi_0 as x and w as v.
// T: one coordinate (double: the GPU box's kernels, gpu/box_kernels.hpp) or
// a particle's vector (Eigen: the CPU integrator below, in SIMD lanes); the
// same operations on each component. Host and device (GRANULAR_HD).
template <class T>
GRANULAR_HD T gear_predict(double dt, T& x, T& v, T& r2, T& r3, T& r4, T& r5) {
  const T r1 = dt * v;
  const T step = r1 + r2 + r3 + r4 + r5;
  x += step;
  v = (r1 + 2.0 * r2 + 3.0 * r3 + 4.0 * r4 + 5.0 * r5) / dt;
  r2 += 3.0 * r3 + 6.0 * r4 + 10.0 * r5;
  r3 += 4.0 * r4 + 10.0 * r5;
  r4 += 5.0 * r5;
  return step;
}

// The corrector: a2 = (dt^2/2) times the acceleration from the forces,
// D = a2 - r_2, r_k += c_k D (c0: c_0, 3/20 or 3/16). T as for gear_predict.
template <class T>
GRANULAR_HD void gear_correct(double c0, double dt, const T& a2, T& x, T& v, T& r2, T& r3, T& r4, T& r5) {
  const T d = a2 - r2;
  x += c0 * d;
  v += (kGearC1 / dt) * d;
  r2 += d;
  r3 += kGearC3 * d;
  r4 += kGearC4 * d;
  r5 += kGearC5 * d;
}

template <int Dim, class Motion = NoMotion>
struct Gear5 {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  using DriftStats = granular::DriftStats;
  static constexpr double kC0 = kGearC0, kC1 = kGearC1, kC3 = kGearC3, kC4 = kGearC4, kC5 = kGearC5;
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
    p.aux_v.assign(4, Column<V>(n, V::Zero()));
    p.aux_a.assign(5, Column<A>(n, A::Zero()));
    const double h2 = 0.5 * dt * dt;
    for (std::size_t i = 0; i < n; ++i) {
      p.aux_v[0][i] = h2 * (p.f[i] * p.inv_m[i] + gravity);
      p.aux_a[1][i] = (h2 * p.inv_i[i]) * p.tq[i];
    }
  }

  // Named views of the aux columns (see start()).
  struct Columns {
    Column<V>&r2, &r3, &r4, &r5;
    Column<A>&q0, &q2, &q3, &q4, &q5;
    explicit Columns(ParticleStore<Dim>& p)
        : r2(p.aux_v[0]), r3(p.aux_v[1]), r4(p.aux_v[2]), r5(p.aux_v[3]), q0(p.aux_a[0]), q2(p.aux_a[1]),
          q3(p.aux_a[2]), q4(p.aux_a[3]), q5(p.aux_a[4]) {}
  };

  template <Wrap W>
  DriftStats first_half(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, const Column<V>& x_ref, std::size_t lo,
                        std::size_t hi, double t_next, const DriftStats& seed = DriftStats()) const {
    return stages<GearPass::predict>(p, domain, x_ref, lo, hi, t_next, seed);
  }

  template <Wrap W>
  void second_half(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, std::size_t lo, std::size_t hi) const {
    stages<GearPass::correct>(p, domain, p.x, lo, hi, 0.0, DriftStats());
  }

  // The corrector of one step and the predictor of the next in one pass:
  // each particle gets the same operations in the same order as from
  // second_half() then first_half() (the same bits), with its fifteen columns
  // read and written once instead of twice.
  template <Wrap W>
  DriftStats second_then_first(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, const Column<V>& x_ref,
                               std::size_t lo, std::size_t hi, double t_next,
                               const DriftStats& seed = DriftStats()) const {
    return stages<GearPass::correct_then_predict>(p, domain, x_ref, lo, hi, t_next, seed);
  }

 private:
  // One particle's columns, loaded once and stored once per pass.
  struct State {
    V x, v, r2, r3, r4, r5;
    A w, q0, q2, q3, q4, q5;
    GRANULAR_INLINE void load(const ParticleStore<Dim>& p, const Columns& c, std::size_t i) {
      x = p.x[i], v = p.v[i], r2 = c.r2[i], r3 = c.r3[i], r4 = c.r4[i], r5 = c.r5[i];
      w = p.w[i], q0 = c.q0[i], q2 = c.q2[i], q3 = c.q3[i], q4 = c.q4[i], q5 = c.q5[i];
    }
    GRANULAR_INLINE void store(ParticleStore<Dim>& p, Columns& c, std::size_t i) const {
      p.x[i] = x, p.v[i] = v, c.r2[i] = r2, c.r3[i] = r3, c.r4[i] = r4, c.r5[i] = r5;
      p.w[i] = w, c.q0[i] = q0, c.q2[i] = q2, c.q3[i] = q3, c.q4[i] = q4, c.q5[i] = q5;
    }
  };

  // The predictor; returns the position's step.
  template <Wrap W>
  GRANULAR_INLINE V predict(State& s, const Domain<Dim, W>& domain) const {
    const V step = gear_predict(dt, s.x, s.v, s.r2, s.r3, s.r4, s.r5);
    domain.wrap(s.x);
    gear_predict(dt, s.q0, s.w, s.q2, s.q3, s.q4, s.q5);
    return step;
  }

  // The corrector, from the forces in the store.
  template <Wrap W>
  GRANULAR_INLINE void correct(State& s, const ParticleStore<Dim>& p, std::size_t i,
                               const Domain<Dim, W>& domain) const {
    const double h2 = 0.5 * dt * dt;
    gear_correct(c0, dt, V(h2 * (p.f[i] * p.inv_m[i] + gravity)), s.x, s.v, s.r2, s.r3, s.r4, s.r5);
    domain.wrap(s.x);
    gear_correct(c0, dt, A((h2 * p.inv_i[i]) * p.tq[i]), s.q0, s.w, s.q2, s.q3, s.q4, s.q5);
  }

  // The corrector and/or the predictor on particles [lo, hi). x_ref, t_next
  // and the statistics belong to the predictor; the corrector alone
  // (second_half) passes placeholders it never reads.
  template <GearPass Pass, Wrap W>
  DriftStats stages(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, const Column<V>& x_ref, std::size_t lo,
                    std::size_t hi, double t_next, const DriftStats& seed) const {
    // A local, returned as a copy (drift_stats.hpp: kept in registers).
    DriftStats st = seed;
    const auto pose = pose_at(motion, t_next);
    Columns c(p);
    for (std::size_t i = lo; i < hi; ++i) {
      if constexpr (Pass != GearPass::correct) {
        if (place_if_wall(motion, pose, p, i, domain, x_ref[i], st)) continue;
      } else if constexpr (kHasMotion<Motion>) {
        if (p.species[i] == kWallSpecies) continue;
      }
      State s;
      s.load(p, c, i);
      if constexpr (Pass != GearPass::predict) correct(s, p, i, domain);
      if constexpr (Pass != GearPass::correct) {
        const V step = predict(s, domain);
        st.add(domain, i, step.squaredNorm(), s.x, x_ref[i]);
      }
      s.store(p, c, i);
    }
    return DriftStats(st);
  }
};

}  // namespace granular
