// A shaken-box run on the GPU path (docs/gpu.md): the CPU engine's run loop
// (engine/box.cpp, run_box), output, health checks and checkpoints, with the
// state stepped by a BoxStepper (gpu/box_gpu.hpp) through the GPU engine's
// driver (gpu/stepper_driver.hpp). A box stepper holds one box: the run has
// one member.
#pragma once
#include <memory>

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
// maker of the stepper of one box (make_host_box, make_cuda_box).
using BoxKind = SceneKind<BoxSim, BoxModel, 2, &box_model, BoxHealth>;
using BoxStepperFactory = StepperFactoryOf<BoxKind>;

// The driver (engine/run_driver.hpp) of the box sim, made from scene s,
// stepped by a stepper from `make`, for run_box.
std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, BoxSim& sim, BoxStepperFactory make);

}  // namespace granular::gpu
