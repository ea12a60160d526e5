// Leapfrog integration in the two-stage form of Rapaport, "The Art of Molecular
// Dynamics Simulation" (the paper's Ref. [32]), used by Rapaport (2002) Sec. III:
//   stage 1:  v += (dt/2) a(t);  r += dt v          -> forces at r(t+dt) with these v
//   stage 2:  v += (dt/2) a(t+dt)
// Angular velocities get the two half kicks only: no rotational coordinates are
// needed. Gravity enters as a constant acceleration.
#pragma once
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/box.hpp"
#include "core/particles.hpp"

namespace granular {

template <int Dim>
struct Leapfrog {
  using V = Vec<Dim>;
  double dt = 0.005;
  V gravity = V::Zero();

  struct DriftStats {
    double max_disp2 = 0.0;   // largest squared displacement since the neighbour-list build
    double next_disp2 = 0.0;  // second largest (two particles approach by at most the sum)
    void push_disp(double d2) {
      if (!(d2 <= max_disp2)) {
        next_disp2 = max_disp2;
        max_disp2 = d2;
      } else {
        next_disp2 = d2;
      }
    }
    double disp_bound() const { return std::sqrt(max_disp2) + std::sqrt(next_disp2); }
    double max_step2 = 0.0;  // largest squared displacement in this step (NaN-safe: see below)
  };

  // Stage 1 on particles [lo, hi).
  //
  // A pair listed at distance > range + skin can only come into range once
  // the sum of the two particles' displacements exceeds the skin, so the list is
  // rebuilt when the two largest displacements add up to more than the skin
  // (less often than the common "largest > skin/2" rule, and as safe).
  DriftStats first_half(ParticleStore<Dim>& p, const Box<Dim>& box, const std::vector<V>& x_ref, std::size_t lo,
                        std::size_t hi) const {
    const double h = 0.5 * dt;
    DriftStats st;
    for (std::size_t i = lo; i < hi; ++i) {
      p.v[i] += h * (p.f[i] * p.inv_m[i] + gravity);
      p.w[i] += (h * p.inv_i[i]) * p.tq[i];
      const V step = dt * p.v[i];
      p.x[i] += step;
      box.wrap(p.x[i]);
      const double s2 = step.squaredNorm();
      const double d2 = box.min_image(p.x[i] - x_ref[i]).squaredNorm();
      // Written so that a NaN makes the statistic NaN-propagating via !(a <= b).
      if (!(s2 <= st.max_step2)) st.max_step2 = s2;
      if (!(d2 <= st.next_disp2)) st.push_disp(d2);
    }
    return st;
  }

  // Stage 2 on particles [lo, hi).
  void second_half(ParticleStore<Dim>& p, std::size_t lo, std::size_t hi) const {
    const double h = 0.5 * dt;
    for (std::size_t i = lo; i < hi; ++i) {
      p.v[i] += h * (p.f[i] * p.inv_m[i] + gravity);
      p.w[i] += (h * p.inv_i[i]) * p.tq[i];
    }
  }
};

}  // namespace granular
