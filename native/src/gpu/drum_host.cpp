// The GPU drum's kernels (gpu/drum_kernels.hpp) built by the host compiler:
// the same source as the CUDA build (gpu/drum_cuda.cu), run as loops on the
// CPU, so that machines without a GPU can check its results against the CPU
// engine (tests/native/test_gpu_drum.cpp).
#include "gpu/drum_kernels.hpp"

namespace granular::gpu {

std::unique_ptr<DrumStepper> make_host_drum(const std::vector<DrumModel>& replicas) {
  return host::make_drum_stepper(replicas);
}

std::unique_ptr<DrumStepper> make_host_drum(const DrumModel& m) { return make_host_drum(std::vector<DrumModel>{m}); }

}  // namespace granular::gpu
