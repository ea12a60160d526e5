// What a GPU stepper (gpu/drum_gpu.hpp, gpu/box_gpu.hpp) throws where a step
// moved a particle further than the CPU engine allows
// (Simulation::max_step_move) or made a position or velocity not finite.
#pragma once
#include <stdexcept>
#include <string>

namespace granular::gpu {

// A step moved a particle of replica `replica` further than max_step_move,
// or made a position or velocity not finite. The stepper stops after that
// step's first stage (its drift or Gear's predictor), before the step is
// counted: the state it holds is the one the CPU engine's check
// (Simulation::report_unstable_step) names the culprit from.
class StepUnstable : public std::runtime_error {
 public:
  explicit StepUnstable(int replica)
      : std::runtime_error("GPU stepper: replica " + std::to_string(replica) + " is unstable"), replica(replica) {}
  int replica;
};

}  // namespace granular::gpu
