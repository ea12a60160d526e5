// The GPU box's kernels (gpu/box_kernels.hpp) built by nvcc into CUDA
// kernels: the same source as the host build (gpu/box_host.cpp).
#include <cuda_runtime.h>

#include "gpu/box_kernels.hpp"
#include "gpu/drum_gpu.hpp"  // cuda_unavailable

namespace granular::gpu {

std::unique_ptr<BoxStepper> make_cuda_box(const std::vector<BoxModel>& replicas) {
  const std::string why = cuda_unavailable();
  if (!why.empty()) throw std::runtime_error(why);
  return cuda::make_box_stepper(replicas);
}

std::unique_ptr<BoxStepper> make_cuda_box(const BoxModel& m) { return make_cuda_box(std::vector<BoxModel>{m}); }

}  // namespace granular::gpu
