// The GPU box's kernels (gpu/box_kernels.hpp) built by the host compiler: the
// same source as the CUDA build (gpu/box_cuda.cu), run as loops on the CPU,
// so that machines without a GPU can check its results against the CPU
// engine (tests/native/test_gpu_box.cpp).
#include "gpu/box_kernels.hpp"

namespace granular::gpu {

std::unique_ptr<BoxStepper> make_host_box(const std::vector<BoxModel>& replicas) {
  return host::make_box_stepper(replicas);
}

std::unique_ptr<BoxStepper> make_host_box(const BoxModel& m) { return make_host_box(std::vector<BoxModel>{m}); }

}  // namespace granular::gpu
