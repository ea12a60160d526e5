#include "gpu/box_run.hpp"

#include "gpu/box_model.hpp"

namespace granular::gpu {

BoxModel BoxKind::model(const BoxSim& sim) { return box_model(sim); }

std::unique_ptr<RunDriver> make_box_driver(const BoxScene& s, BoxSim& sim, BoxStepperFactory make) {
  return make_stepper_driver<BoxKind>(make_box(s), {&sim}, make, {});
}

}  // namespace granular::gpu
