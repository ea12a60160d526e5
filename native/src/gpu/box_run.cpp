#include "gpu/box_run.hpp"

#include <stdexcept>
#include <utility>

namespace granular::gpu {

std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, std::vector<BoxSim*> sims, BoxStepperFactory make,
                                           std::vector<std::string> labels) {
  if (sims.empty()) throw std::invalid_argument("make_box_driver: no box");
  return make_stepper_driver<BoxKind>(make_box(s), std::move(sims), make, std::move(labels));
}

std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, BoxSim& sim, BoxStepperFactory make) {
  return make_box_driver(s, std::vector<BoxSim*>{&sim}, make);
}

}  // namespace granular::gpu
