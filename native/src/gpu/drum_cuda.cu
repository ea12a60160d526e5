// The GPU drum's kernels (gpu/drum_kernels.hpp) built by nvcc into CUDA
// kernels: the same source as the host build (gpu/drum_host.cpp).
#include <cuda_runtime.h>

#include "gpu/drum_kernels.hpp"

namespace granular::gpu {

std::string cuda_unavailable() {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess) return std::string("no CUDA device is visible (") + cudaGetErrorString(e) + ")";
  if (count == 0) return "no CUDA device is visible";
  return "";
}

std::size_t cuda_free_bytes() {
  std::size_t free = 0, total = 0;
  check(cudaMemGetInfo(&free, &total), "cudaMemGetInfo");
  return free;
}

std::unique_ptr<DrumStepper> make_cuda_drum(const std::vector<DrumModel>& replicas) {
  const std::string why = cuda_unavailable();
  if (!why.empty()) throw std::runtime_error(why);
  return cuda::make_drum_stepper(replicas);
}

}  // namespace granular::gpu
