// Periodic axes as a boundary: Rapaport (2002) Sec. III runs the drum with
// "periodic or capped ends". With this boundary among a simulation's walls,
// its box may wrap along the axes the scene marks periodic (Box::periodic):
// positions wrap into the box and every separation takes the minimum image.
// Without it the box is open, and both operations compile to nothing
// (core/box.hpp). It exerts no force.
#pragma once
#include <cstddef>

#include "core/particles.hpp"

namespace granular {

struct PeriodicAxes {
  // Cost per particle in listed pairs (neighbor/neighbor_list.hpp): none
  // here; the wrap is part of the integrator's drift.
  static constexpr unsigned kWeight = 0;

  template <class Law, int Dim>
  void apply(ParticleStore<Dim>&, const Law&, std::size_t, std::size_t, double) const {}
};

}  // namespace granular
