// What the integrators report after moving particles: how far they went, for
// the neighbour-list skin test and the stability check.
//
// A pair listed at distance > range + skin can only come into range once the
// sum of the two particles' displacements exceeds the skin, so the list is
// rebuilt when the two largest displacements since the build add up to more
// than the skin (less often than the common "largest > skin/2" rule, and as safe).
#pragma once
#include <cmath>

#include "core/box.hpp"

namespace granular {

// An integrator sums these in a local and returns a copy (`return
// DriftStats(st)`), not the local itself: a named return value lives in the
// caller's return slot, memory the stores to the particles' columns might
// alias, so the sums would be reloaded and stored on every particle; a local
// whose address never escapes stays in registers.
struct DriftStats {
  double max_disp2 = 0.0;   // largest squared displacement since the neighbour-list build
  double next_disp2 = 0.0;  // second largest
  double max_step2 = 0.0;   // largest squared displacement in this step (NaN-propagating)

  void push_disp(double d2) {
    if (!(d2 <= max_disp2)) {
      next_disp2 = max_disp2;
      max_disp2 = d2;
    } else {
      next_disp2 = d2;
    }
  }
  double disp_bound() const { return std::sqrt(max_disp2) + std::sqrt(next_disp2); }

  // s2: squared displacement in this step; x, ref: position now and at the
  // last build. Written with !(a <= b) so that a NaN makes the statistics NaN.
  template <int Dim>
  void add(const Box<Dim>& box, double s2, const Vec<Dim>& x, const Vec<Dim>& ref) {
    const double d2 = box.min_image(x - ref).squaredNorm();
    if (!(s2 <= max_step2)) max_step2 = s2;
    if (!(d2 <= next_disp2)) push_disp(d2);
  }
};

}  // namespace granular
