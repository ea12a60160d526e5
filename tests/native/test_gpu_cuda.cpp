// The GPU drum's CUDA build (gpu/drum_cuda.cu) against its host build
// (gpu/drum_host.cpp), which tests/native/test_gpu_drum.cpp checks against
// the CPU engine. Built only when CMake finds CUDA; each test is skipped,
// saying why, where no CUDA device is visible (scripts/gpu_check.sh runs
// them on a GPU machine).
//
// Both builds evaluate the same operations in the same order (nvcc with
// -fmad=false, the host with -ffp-contract=off; double division and square
// root correctly rounded on both) and list and sum each particle's contacts
// in the same order (a stable sort by cell), so they are expected to agree
// bit for bit; the tests allow 1e-12 of each quantity's largest magnitude,
// the bound the GPU path is held to against the CPU engine, and print the
// difference measured.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "gpu/drum_gpu.hpp"
#include "gpu/drum_model.hpp"
#include "scene/scene_file.hpp"

using namespace granular;

namespace {

std::string source_dir() {
  const char* s = std::getenv("GRANULAR_SOURCE_DIR");
  return s ? s : ".";
}

gpu::DrumModel drum_a_model(std::vector<std::string> sets) {
  SceneFile f(source_dir() + "/scenes/drum/A.toml", std::move(sets));
  const DrumSim sim = make_drum(read_drum_scene(f));
  return gpu::drum_model(sim);
}

// The largest difference of a per-particle vector quantity between two
// stores in the same order, relative to its largest magnitude.
template <class Column>
double relative_difference(const Column& a, const Column& b) {
  double d = 0.0, s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    d = std::max(d, (a[i] - b[i]).cwiseAbs().maxCoeff());
    s = std::max(s, a[i].cwiseAbs().maxCoeff());
  }
  return s > 0.0 ? d / s : d;
}

#define SKIP_WITHOUT_CUDA_DEVICE()                       \
  do {                                                   \
    const std::string why = gpu::cuda_unavailable();     \
    if (!why.empty()) GTEST_SKIP() << why;               \
  } while (0)

class GpuDrumCuda : public testing::TestWithParam<std::string> {};

// One step from the lattice of drum #A at L = 8 (264 particles, every pair
// and wall contact of the first step), then 200 steps (the collapse: list
// builds, many contacts): forces, torques, positions, velocities and spins.
// Two replicas (seeds 1 and 2) in one stepper, so the replicas' cell keys and
// per-replica list builds run on the device too.
TEST_P(GpuDrumCuda, GivesTheHostBuildsResults) {
  SKIP_WITHOUT_CUDA_DEVICE();
  constexpr double kTol = 1e-12;
  std::vector<gpu::DrumModel> models;
  for (const char* seed : {"particles.seed=1", "particles.seed=2"})
    models.push_back(drum_a_model({"drum.length=8", "contact.law=" + GetParam(), seed}));
  const auto host = gpu::make_host_drum(models);
  const auto cuda = gpu::make_cuda_drum(models);
  EXPECT_STREQ(cuda->backend(), "cuda");
  ASSERT_EQ(cuda->replicas(), 2);
  for (const long steps : {1L, 199L}) {
    host->advance(steps);
    cuda->advance(steps);
    EXPECT_EQ(cuda->step_count(), host->step_count());
    EXPECT_EQ(cuda->builds(), host->builds());
    for (int r = 0; r < 2; ++r) {
      ParticleStore<3> h = models[r].p, c = models[r].p;
      host->download(h, r);
      cuda->download(c, r);
      const double df = relative_difference(h.f, c.f), dt = relative_difference(h.tq, c.tq);
      const double dx = relative_difference(h.x, c.x), dv = relative_difference(h.v, c.v),
                   dw = relative_difference(h.w, c.w);
      std::printf("%s replica %d after %ld steps (%ld list builds): relative differences f %.3g, torque %.3g, "
                  "x %.3g, v %.3g, w %.3g\n",
                  GetParam().c_str(), r, host->step_count(), host->builds(), df, dt, dx, dv, dw);
      EXPECT_LE(df, kTol);
      EXPECT_LE(dt, kTol);
      EXPECT_LE(dx, kTol);
      EXPECT_LE(dv, kTol);
      EXPECT_LE(dw, kTol);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Laws, GpuDrumCuda, testing::Values("rapaport", "linear", "viscel"),
                         [](const auto& info) { return info.param; });

}  // namespace
