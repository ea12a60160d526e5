// A drum run on the GPU path (docs/gpu.md): the CPU engine's run loop
// (engine/drum.cpp, run_drums), output, health checks and checkpoints, with
// the state stepped by a DrumStepper (gpu/drum_gpu.hpp) through the GPU
// engine's driver (gpu/stepper_driver.hpp).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "engine/drum.hpp"
#include "gpu/drum_gpu.hpp"
#include "gpu/drum_model.hpp"
#include "gpu/stepper_driver.hpp"
#include "scene/drum_scene.hpp"

namespace granular::gpu {

// The drum's health check: engine/health.hpp's, over the listed pairs.
struct DrumHealth {
  template <class Sim>
  void operator()(const Sim& sim, const HealthLimits& lim) const {
    granular::check_health(sim, lim);
  }
};

// The drum's part of the driver (gpu/stepper_driver.hpp, SceneKind), and the
// maker of the stepper of one or several replicas (make_host_drum,
// make_cuda_drum).
using DrumKind = SceneKind<DrumSim, DrumModel, 3, &drum_model, DrumHealth>;
using StepperFactory = StepperFactoryOf<DrumKind>;

// The driver (engine/run_driver.hpp) of the drums sims[0..K) (one scene, K
// seeds), stepped together as the replicas of one stepper from `make`
// (gpu/stepper_driver.hpp says what is downloaded when, and how the health
// check and checkpoints work). labels[r] names member r in the message of an
// instability when K > 1.
std::unique_ptr<RunDriver> make_drum_driver(const DrumScene& s, std::vector<DrumSim*> sims, StepperFactory make,
                                            std::vector<std::string> labels = {});

}  // namespace granular::gpu
