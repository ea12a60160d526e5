// Periodic axes as a boundary: Rapaport (2002) Sec. III runs the drum with
// "periodic or capped ends". With this boundary among a simulation's walls,
// its domain may wrap along the axes the scene marks periodic (Domain::periodic):
// positions wrap into the domain and every separation takes the minimum image.
// Without it the domain is open, and both operations compile to nothing
// (core/domain.hpp). It exerts no force.
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
