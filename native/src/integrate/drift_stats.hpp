// What the integrators report after moving particles: how far they went, for
// the neighbour-list skin test and the stability check.
//
// A pair listed at distance > range + skin can only come into range once the
// sum of the two particles' displacements exceeds the skin, so the list is
// valid while the two largest displacements since the build add up to no
// more than the skin (less often than the common "largest > skin/2" rule, and
// as safe). Past that point the stage also names the fast particles, those
// that moved more than skin/2 (d2 > fast2): every pair not involving one of
// them is still safe, and the neighbour list checks the fast ones' pairs one
// by one (NeighborList::fast_pairs_listed) before a rebuild is called for.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "core/domain.hpp"

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
  // The fast particles: the indices of the first cap_fast with a squared
  // displacement above fast2 go to fast (a buffer of the caller's); n_fast
  // counts all of them. Without a buffer (the default) only the count.
  double fast2 = std::numeric_limits<double>::infinity();
  std::uint32_t* fast = nullptr;
  std::uint32_t n_fast = 0, cap_fast = 0;

  // Empty statistics that name fast particles into `buffer` (room for `cap`)
  // beyond a displacement of `threshold`.
  static DriftStats naming_fast(double threshold, std::uint32_t* buffer, std::uint32_t cap) {
    DriftStats s;
    s.fast2 = threshold * threshold;
    s.fast = buffer;
    s.cap_fast = cap;
    return s;
  }

  void push_disp(double d2) {
    if (!(d2 <= max_disp2)) {
      next_disp2 = max_disp2;
      max_disp2 = d2;
    } else {
      next_disp2 = d2;
    }
  }
  double disp_bound() const { return std::sqrt(max_disp2) + std::sqrt(next_disp2); }

  // Adds another thread's statistics (the largest step, the two largest
  // displacements of both, the fast particles counted). The names of the
  // fast particles stay in each thread's buffer.
  void combine(const DriftStats& s) {
    if (!(s.max_step2 <= max_step2)) max_step2 = s.max_step2;
    if (!(s.next_disp2 <= next_disp2)) push_disp(s.next_disp2);
    if (!(s.max_disp2 <= next_disp2)) push_disp(s.max_disp2);
    n_fast += s.n_fast;
  }

  // Particle i. s2: squared displacement in this step; x, ref: position now
  // and at the last build. Written with !(a <= b) so that a NaN makes the
  // statistics NaN.
  template <int Dim, Wrap W>
  void add(const Domain<Dim, W>& domain, std::size_t i, double s2, const Vec<Dim>& x, const Vec<Dim>& ref) {
    const double d2 = domain.min_image(x - ref).squaredNorm();
    if (!(s2 <= max_step2)) max_step2 = s2;
    if (!(d2 <= fast2)) {
      if (n_fast < cap_fast) fast[n_fast] = static_cast<std::uint32_t>(i);
      ++n_fast;
    }
    if (!(d2 <= next_disp2)) push_disp(d2);
  }
};

}  // namespace granular
