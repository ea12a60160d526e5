// A shaken-box run on the GPU path (docs/gpu.md): the CPU engine's run loop
// (engine/box.cpp, run_box), output, health checks and checkpoints, with the
// state stepped by a BoxStepper (gpu/box_gpu.hpp) through the GPU engine's
// driver (gpu/stepper_driver.hpp): one box, or the replicas of one scene
// (K seeds) stepped together.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "engine/box.hpp"
#include "gpu/box_gpu.hpp"
#include "gpu/box_model.hpp"
#include "gpu/stepper_driver.hpp"
#include "scene/box_scene.hpp"

namespace granular::gpu {

// The box's health check (engine/box.hpp, check_box_health): the listed
// pairs' overlaps and the smooth walls'.
struct BoxHealth {
  template <class Sim>
  void operator()(const Sim& sim, const HealthLimits& lim) const {
    check_box_health(sim, lim);
  }
};

// The box's part of the driver (gpu/stepper_driver.hpp, SceneKind), and the
// maker of the stepper of one or several replicas (make_host_box,
// make_cuda_box).
using BoxKind = SceneKind<BoxSim, BoxModel, 2, &box_model, BoxHealth>;
using BoxStepperFactory = StepperFactoryOf<BoxKind>;

// The driver (engine/run_driver.hpp) of the boxes sims[0..K) (one scene, K
// seeds), stepped together as the replicas of one stepper from `make`, for
// run_boxes. labels[r] names member r in the message of an instability when
// K > 1.
std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, std::vector<BoxSim*> sims, BoxStepperFactory make,
                                           std::vector<std::string> labels = {});
// The driver of the one box sim, for run_box.
std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, BoxSim& sim, BoxStepperFactory make);

}  // namespace granular::gpu
