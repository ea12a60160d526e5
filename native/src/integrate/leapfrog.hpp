// Leapfrog integration in the two-stage form of Rapaport, "The Art of Molecular
// Dynamics Simulation" (the paper's Ref. [32]), used by Rapaport (2002) Sec. III:
//   stage 1:  v += (dt/2) a(t);  r += dt v          -> forces at r(t+dt) with these v
//   stage 2:  v += (dt/2) a(t+dt)
// (the steps of LAMMPS's velocity Verlet, fix nve/sphere). Angular velocities
// get the two half kicks only: no rotational coordinates are needed. Gravity
// enters as a constant acceleration.
// Wall particles (Motion != NoMotion) are placed, not integrated. Between two
// steps the engine runs stage 2 and the next stage 1 as one pass
// (second_then_first): the same arithmetic, each column touched once.
#pragma once
#include <cmath>
#include <cstddef>
#include <vector>

#include "contact/lane.hpp"  // GRANULAR_HD
#include "core/domain.hpp"
#include "core/particles.hpp"
#include "integrate/drift_stats.hpp"
#include "integrate/motion.hpp"

namespace granular {

// The half kick, v += (dt/2) a with a = f/m + g, and the angular one,
// w += ((dt/2)/I) t (h = dt/2, h_inv_i = (dt/2)/I); the drift, x += dt v,
// returning the step dt v. T: one component (double: the GPU path's
// kernels, gpu/drum_kernels.hpp and gpu/box_kernels.hpp) or a particle's
// vector (Eigen: the CPU integrator below, in SIMD lanes); the same
// operations on each component. Host and device (GRANULAR_HD).
template <class T>
GRANULAR_HD void leapfrog_kick(double h, const T& f, double inv_m, const T& g, T& v) {
  v += h * (f * inv_m + g);
}
template <class T>
GRANULAR_HD void leapfrog_spin_kick(double h_inv_i, const T& t, T& w) {
  w += h_inv_i * t;
}
template <class T>
GRANULAR_HD T leapfrog_drift(double dt, const T& v, T& x) {
  const T step = dt * v;
  x += step;
  return step;
}

template <int Dim, class Motion = NoMotion>
struct Leapfrog {
  using V = Vec<Dim>;
  using DriftStats = granular::DriftStats;
  double dt = 0.005;
  V gravity = V::Zero();
  Motion motion{};
  // Cost per particle and step (both stages) in listed pairs, for the
  // threads' blocks (neighbor/neighbor_list.hpp): 10 ns in the box.
  static constexpr unsigned kWeight = 5;

  void start(ParticleStore<Dim>&) const {}

  // Stage 1 on particles [lo, hi); t_next = time at the end of the step. The
  // statistics start from seed (where to name fast particles: drift_stats.hpp).
  template <Wrap W>
  DriftStats first_half(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, const Column<V>& x_ref, std::size_t lo,
                        std::size_t hi, double t_next, const DriftStats& seed = DriftStats()) const {
    return kicks_then_drift<1>(p, domain, x_ref, lo, hi, t_next, seed);
  }

  // Stage 2 on particles [lo, hi).
  template <Wrap W>
  void second_half(ParticleStore<Dim>& p, const Domain<Dim, W>&, std::size_t lo, std::size_t hi) const {
    for (std::size_t i = lo; i < hi; ++i) {
      if constexpr (kHasMotion<Motion>)
        if (p.species[i] == kWallSpecies) continue;
      V v = p.v[i];
      A w = p.w[i];
      kick(p, i, v, w);
      p.v[i] = v;
      p.w[i] = w;
    }
  }

  // Stage 2 of one step and stage 1 of the next in one pass: both kicks use
  // the same forces, so each particle gets the same operations in the same
  // order as from second_half() then first_half() (the same bits), with its
  // columns read and written once instead of twice.
  template <Wrap W>
  DriftStats second_then_first(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, const Column<V>& x_ref,
                               std::size_t lo, std::size_t hi, double t_next,
                               const DriftStats& seed = DriftStats()) const {
    return kicks_then_drift<2>(p, domain, x_ref, lo, hi, t_next, seed);
  }

 private:
  using A = Ang<Dim>;

  // Half a step's kick from the forces in the store.
  GRANULAR_INLINE void kick(const ParticleStore<Dim>& p, std::size_t i, V& v, A& w) const {
    const double h = 0.5 * dt;
    leapfrog_kick(h, p.f[i], p.inv_m[i], gravity, v);
    leapfrog_spin_kick(h * p.inv_i[i], p.tq[i], w);
  }

  // Kicks half kicks, then the drift, on particles [lo, hi).
  template <int Kicks, Wrap W>
  DriftStats kicks_then_drift(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, const Column<V>& x_ref,
                              std::size_t lo, std::size_t hi, double t_next, const DriftStats& seed) const {
    // A local, returned as a copy (drift_stats.hpp: kept in registers).
    DriftStats st = seed;
    const auto pose = pose_at(motion, t_next);
    for (std::size_t i = lo; i < hi; ++i) {
      if (place_if_wall(motion, pose, p, i, domain, x_ref[i], st)) continue;
      // Work on copies and store each column once: reading back a position
      // just stored in pieces (the periodic wrap writes one component) stalls
      // the load on the pending stores.
      V v = p.v[i];
      A w = p.w[i];
      for (int k = 0; k < Kicks; ++k) kick(p, i, v, w);
      p.v[i] = v;
      p.w[i] = w;
      V x = p.x[i];
      const V step = leapfrog_drift(dt, v, x);
      domain.wrap(x);
      p.x[i] = x;
      st.add(domain, i, step.squaredNorm(), x, x_ref[i]);
    }
    return DriftStats(st);
  }
};

}  // namespace granular
