// A run whose state is stepped elsewhere than in its simulations (the GPU
// engine, gpu/stepper_driver.hpp): the CPU engine's run loop (engine/drum.cpp,
// run_drums; engine/box.cpp, run_box) gives it the steps and asks it for the
// state where the run observes, checks or checkpoints. The run's members are
// simulations of one scene stepped side by side (a drum's or a box's
// replicas; a single run has one member, r = 0); member r's simulation holds
// the scene's model and, once fetched, the state.
#pragma once
#include <cstddef>

#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "engine/run_control.hpp"

namespace granular {

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
