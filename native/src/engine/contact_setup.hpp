// The contact law of a 3D scene of Rapaport's particles (m = d^3,
// I = kappa m d^2 / 2, Sec. III) and smooth walls of diameter d_w, set once on
// a simulation whose type already names the law: Rapaport's law as the paper
// gives it (Eqs. (1)-(5)), or the linear law mapped from it, or YADE's
// viscoelastic law mapped from that (scene/law_mapping.hpp). For the mapped
// laws the particles' contact diameters become 2^(1/6) d (masses unchanged,
// inertia kappa m d^2 / 2 of the contact diameter; LAMMPS: 2/5 m r^2) and the
// walls have zero thickness, moved in by 2^(1/6) d_w / 2, so that contacts
// begin where they begin under Rapaport's law. The drum and the particles
// scene share it.
#pragma once
#include <type_traits>

#include "contact/laws.hpp"
#include "scene/law_mapping.hpp"

namespace granular {

// Where the walls' contacts are computed: the wall diameter d_w the law sees,
// and how far each wall surface moves towards the particles.
struct WallGeometry {
  double d_wall = 1.0;
  double inset = 0.0;
};

// Call after the particles are in sim.p: the law from its from_rapaport
// (contact/laws.hpp), the particles' contact diameters and inertia where the
// law's map scales them.
template <class Sim>
WallGeometry set_contact_law(Sim& sim, const MappingInputs& in, double kappa) {
  using Law = std::decay_t<decltype(sim.law)>;
  const MappedLaw<Law> m = Law::from_rapaport(in);
  sim.law = m.law;
  if (m.diameter_scale != 1.0) {
    for (std::size_t i = 0; i < sim.p.size(); ++i) {
      sim.p.d[i] *= m.diameter_scale;
      const double mass = 1.0 / sim.p.inv_m[i], d = sim.p.d[i];
      sim.p.inv_i[i] = 1.0 / (0.5 * kappa * mass * d * d);
    }
  }
  return {m.d_wall, m.wall_inset};
}

}  // namespace granular
