#include "gpu/box_run.hpp"

namespace granular::gpu {

std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, BoxSim& sim, BoxStepperFactory make) {
  return make_stepper_driver<BoxKind>(make_box(s), {&sim}, make, {});
}

}  // namespace granular::gpu
