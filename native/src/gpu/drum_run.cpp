#include "gpu/drum_run.hpp"

#include <stdexcept>
#include <utility>

namespace granular::gpu {

std::unique_ptr<RunDriver> make_drum_driver(const DrumScene& s, std::vector<DrumSim*> sims, StepperFactory make,
                                            std::vector<std::string> labels) {
  if (sims.empty()) throw std::invalid_argument("make_drum_driver: no drum");
  return make_stepper_driver<DrumKind>(make_drum(s), std::move(sims), make, std::move(labels));
}

}  // namespace granular::gpu
