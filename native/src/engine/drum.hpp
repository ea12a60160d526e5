// The drum scene as a simulation: the scene layer maps a DrumScene to one
// concrete Simulation type (periodic or capped ends) held in a std::variant and
// visited once; everything below the visit is statically typed.
#pragma once
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "boundary/cylinder_wall.hpp"
#include "boundary/end_caps.hpp"
#include "boundary/periodic_axes.hpp"
#include "contact/laws.hpp"
#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "engine/run_control.hpp"
#include "engine/run_driver.hpp"
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"
#include "io/h5_output.hpp"
#include "scene/drum_scene.hpp"
#include "scene/law_mapping.hpp"

namespace granular {

template <class Law>
using DrumPeriodicT = Simulation<3, Law, Leapfrog<3>, CylinderWall, PeriodicAxes>;
template <class Law>
using DrumCappedT = Simulation<3, Law, Leapfrog<3>, CylinderWall, EndCaps>;
using DrumPeriodic = DrumPeriodicT<RapaportLaw<3>>;
using DrumCapped = DrumCappedT<RapaportLaw<3>>;
// Every registered law a scene of Rapaport's particles can use
// (contact/laws.hpp: Rapaport's law, LAMMPS's linear law mapped from it,
// YADE's viscoelastic law mapped from that), with periodic or capped ends.
using DrumLaws = RapaportSceneLaws<MappingInputs>;
template <class Law>
using DrumEnds = TypeList<DrumPeriodicT<Law>, DrumCappedT<Law>>;
using DrumSim = VariantOf<FlatMap<DrumEnds, DrumLaws>>;

DrumSim make_drum(const DrumScene& s);

// Volume-weighted (d^3) fraction of small particles in axial slices with the
// given edges along y; NaN for an empty slice.
std::vector<double> axial_small_fraction(const ParticleStore<3>& p, const std::vector<double>& edges);

// Runs s.rotations rotations, writing frames and profiles to `out` (may be null).
// `progress` = show a progress line on stderr. ctl: checkpoints, and the state
// to resume from (then `out` must have been opened for resuming).
RunReport run_drum(const DrumScene& s, DrumSim& sim, H5Output* out, bool progress,
                   const RunControl& ctl = RunControl{});

// One drum of a run (engine/run_driver.hpp).
using DrumMember = RunMember<DrumSim>;

// Runs every member s.rotations rotations (members of one scene, so one
// schedule of output and checks; their simulations the same alternative),
// stepped by the driver (engine/run_driver.hpp; member r is the driver's r).
RunReport run_drums(const DrumScene& s, std::vector<DrumMember>& members, RunDriver& driver, bool progress);

// Settle for `settle` rotations, then time `rotations` rotations.
// For `granular bench`: the drum after `settle` rotations (no output), and
// `rotations` more timed from that state (advancing it).
DrumSim settle_drum(const DrumScene& s, double settle);
RunReport time_drum(const DrumScene& s, DrumSim& sim, double rotations);

}  // namespace granular
