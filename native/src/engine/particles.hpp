// The particles scene as a simulation (docs/particles_scene.md): spheres and
// plane walls in an open domain. The scene layer maps a ParticlesScene to one
// concrete Simulation type per contact law, held in a std::variant and
// visited once; everything below the visit is statically typed.
#pragma once
#include <variant>

#include "boundary/plane_walls.hpp"
#include "contact/laws.hpp"
#include "engine/drum.hpp"  // RunReport
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"
#include "io/h5_output.hpp"
#include "scene/particles_scene.hpp"

namespace granular {

template <class Law>
using ParticlesSimT = Simulation<3, Law, Leapfrog<3>, PlaneWalls>;
// Every registered law a scene of Rapaport's particles can use
// (contact/laws.hpp), as for the drum.
template <class Law>
using ParticlesSims = TypeList<ParticlesSimT<Law>>;
using ParticlesSim = VariantOf<FlatMap<ParticlesSims, RapaportSceneLaws<MappingInputs>>>;

ParticlesSim make_particles(const ParticlesScene& s);

// Runs s.duration time units, writing a frame every s.snapshot_every (and the
// last state) to `out` (may be null). `progress` = show a progress line on
// stderr. Stops with UnstableError (engine/health.hpp) on an unstable run or
// a particle behind a wall.
RunReport run_particles(const ParticlesScene& s, ParticlesSim& sim, H5Output* out, bool progress);

}  // namespace granular
