// A run whose state is stepped elsewhere than in its simulations (the GPU
// engine, gpu/stepper_driver.hpp): the CPU engine's run loop (engine/drum.cpp,
// run_drums; engine/box.cpp, run_box) gives it the steps and asks it for the
// state where the run observes, checks or checkpoints. The run's members are
// simulations of one scene stepped side by side (a drum's or a box's
// replicas; a single run has one member, r = 0); member r's simulation holds
// the scene's model and, once fetched, the state.
#pragma once
#include <cstddef>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "engine/run_control.hpp"

namespace granular {

class H5Output;  // io/h5_output.hpp

class RunDriver {
 public:
  virtual ~RunDriver() = default;
  // Member r's state from its checkpoint into its simulation (before start).
  virtual void restore(std::size_t r, const CheckpointData& c) = 0;
  // Every member's simulation holds the state to step from (new or restored).
  virtual void start() = 0;
  // n steps of every member; each simulation's time and step count follow.
  // Throws UnstableError as Simulation::advance does.
  virtual void advance(long n) = 0;
  // Member r's current state into its simulation's store.
  virtual void fetch(std::size_t r) = 0;
  // The scene's health check (engine/health.hpp, and the box's smooth walls)
  // of every member (throws its UnstableError).
  virtual void check_health(const HealthLimits& lim) = 0;
  // Member r's Coulomb census (engine/coulomb_census.hpp) of its fetched state.
  virtual CoulombCensus census(std::size_t r) = 0;
  // Member r's state as a checkpoint holds it (engine/checkpoint.hpp, capture).
  virtual void capture(std::size_t r, CheckpointData& c) = 0;
};

// One member of a run: its simulation (a scene's variant of simulation
// types: DrumSim, BoxSim), its output (may be null) and its checkpoints.
template <class SimVariant>
struct RunMember {
  SimVariant* sim;
  H5Output* out;
  RunControl ctl;
};

// The members' simulations as the alternative Sim of their variant; `run`
// names the run loop for the message when a member's model is another.
template <class Sim, class SimVariant>
std::vector<Sim*> member_sims(std::vector<RunMember<SimVariant>>& ms, const char* run) {
  std::vector<Sim*> sims;
  for (RunMember<SimVariant>& m : ms) {
    if (!std::holds_alternative<Sim>(*m.sim))
      throw std::logic_error(std::string(run) + ": the members' models differ");
    sims.push_back(&std::get<Sim>(*m.sim));
  }
  return sims;
}

// n steps of a run: by its driver where it has one (driver not null), else
// by its simulation.
template <class Sim>
void advance_run(RunDriver* driver, Sim& sim, long n) {
  if (driver)
    driver->advance(n);
  else
    sim.advance(n);
}

// A run's health check: its driver's where it has one, else cpu_check().
template <class Check>
void check_run_health(RunDriver* driver, const HealthLimits& lim, Check&& cpu_check) {
  if (driver)
    driver->check_health(lim);
  else
    cpu_check();
}

}  // namespace granular
