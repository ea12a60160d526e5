// The shaken box as a simulation: the scene's contact law, integrator and
// walls pick one concrete Simulation type (held in a std::variant, visited
// once). Walls of particles are moved by the integrator (ShakerMotion); smooth
// walls are a boundary (FlatBoxWalls) and the integrator moves nothing.
#pragma once
#include <sstream>
#include <variant>
#include <vector>

#include "boundary/flat_box_walls.hpp"
#include "contact/laws.hpp"
#include "engine/drum.hpp"  // RunReport
#include "engine/health.hpp"
#include "engine/run_driver.hpp"
#include "engine/simulation.hpp"
#include "integrate/gear.hpp"
#include "integrate/leapfrog.hpp"
#include "integrate/motion.hpp"
#include "io/h5_output.hpp"
#include "scene/box_scene.hpp"

namespace granular {

// box.walls = "particles": walls of particles moved by the integrator.
template <class Law, template <int, class> class Integrator>
using ParticleWallBoxOf = Simulation<2, Law, Integrator<2, ShakerMotion<2>>>;
// box.walls = "smooth": the same laws and integrators, without wall particles.
template <class Law, template <int, class> class Integrator>
using SmoothBoxOf = Simulation<2, Law, Integrator<2, NoMotion>, FlatBoxWalls>;
// Every registered law the box can use (contact/laws.hpp: Poeschel and
// Herrmann's, either reading of its damping; YADE's viscoelastic law), with
// either integrator (integrator.kind "leapfrog" or "gear") and either wall.
using BoxLaws = BoxSceneLaws<BoxScene>;
template <class Law>
using BoxChoices = TypeList<ParticleWallBoxOf<Law, Gear5>, ParticleWallBoxOf<Law, Leapfrog>, SmoothBoxOf<Law, Gear5>,
                            SmoothBoxOf<Law, Leapfrog>>;
using BoxSim = VariantOf<FlatMap<BoxChoices, BoxLaws>>;

// The shaker's motion y_box(t) of a box simulation, wherever its type keeps it.
template <class Sim>
const ShakerMotion<2>& shaker_of(const Sim& sim) {
  if constexpr (Sim::template kHasWall<FlatBoxWalls>)
    return std::get<FlatBoxWalls>(sim.walls).shaker;
  else
    return sim.integrator.motion;
}

BoxSim make_box(const BoxScene& s);

// The box's health check: engine/health.hpp's, over the pairs of the
// neighbour list (the wall particles' contacts among them), and the smooth
// walls' overlaps, which are not in the list, against the same limit.
template <class Sim>
void check_box_health(const Sim& sim, const HealthLimits& lim) {
  check_health(sim, lim);
  if constexpr (Sim::template kHasWall<FlatBoxWalls>) {
    const auto o = std::get<FlatBoxWalls>(sim.walls).deepest(sim.p, sim.time);
    if (o.fraction <= lim.max_overlap) return;
    std::ostringstream os;
    os << "simulation unstable at step " << sim.step_count << " (t = " << sim.time << "): particle id "
       << sim.p.id[o.index] << " overlaps the " << o.wall << " by " << 100.0 * o.fraction
       << " % of its contact distance with the wall (limit " << 100.0 * lim.max_overlap
       << " %): the contacts are too soft for the load, or a collision was not resolved. Likely cause: "
       << lim.dt_hint() << ", or a contact stiffness too low for the weight it carries.";
    throw UnstableError(os.str());
  }
}

// Settles for s.settle seconds (walls at rest), then shakes for s.duration.
// Writes snapshots (with contact forces) at the vibration's nodes and the big
// disk's trajectory to `out` (may be null). Stops with UnstableError if a
// grain leaves the box.
// ctl: checkpoints, and the state to resume from (engine/run_control.hpp).
RunReport run_box(const BoxScene& s, BoxSim& sim, H5Output* out, bool progress, const RunControl& ctl = RunControl{});
// The same run with the state stepped by a driver (engine/run_driver.hpp; the
// GPU engine, gpu/box_run.hpp): sim, its one member (r = 0), holds the
// scene's model and, once fetched, the state.
RunReport run_box(const BoxScene& s, BoxSim& sim, H5Output* out, bool progress, const RunControl& ctl,
                  RunDriver& driver);

// One box of a run (engine/run_driver.hpp).
using BoxMember = RunMember<BoxSim>;

// Runs every member (boxes of one scene, other seeds: one schedule of
// output and checks; their simulations the same alternative) stepped by the
// driver (member r is the driver's r), as run_box runs one.
RunReport run_boxes(const BoxScene& s, std::vector<BoxMember>& members, RunDriver& driver, bool progress);

// For `granular bench`: the box after `settle` seconds of settling (no
// output), and `seconds` of shaking timed from that state (advancing it).
BoxSim settle_box(const BoxScene& s, double settle);
RunReport time_box(const BoxScene& s, BoxSim& sim, double seconds);

}  // namespace granular
