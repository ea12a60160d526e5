// The drum on the GPU path (docs/gpu.md): a drum's step (the rotating
// cylinder wall, periodic ends or end caps, the leapfrog, any registered 3D
// contact law) written once as kernels (gpu/drum_kernels.hpp) and built twice:
// by nvcc into CUDA kernels (gpu/drum_cuda.cu, with GRANULAR_HAVE_CUDA) and by
// the host compiler into plain loops (gpu/drum_host.cpp), which the tests
// check against the CPU engine on machines without a GPU.
//
// The interface is backend-neutral: a DrumModel (everything a step needs, as
// plain values, taken from a CPU drum simulation so that both start from the
// same scene path and the same state) and a DrumStepper that advances it.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <type_traits>

#include "boundary/cylinder_wall.hpp"
#include "boundary/end_caps.hpp"
#include "contact/laws.hpp"
#include "core/particles.hpp"
#include "core/type_list.hpp"

namespace granular::gpu {

// The laws the GPU drum runs: every registered law written for 3D (the
// drum's laws, engine/drum.hpp's DrumLaws; gpu/drum_model.cpp checks that the
// two lists agree).
template <class Law>
struct WrittenFor3D : std::bool_constant<Law::kInDim> {};
using DrumGpuLaws = Filter<WrittenFor3D, ContactLaws<3>>;
using DrumGpuLaw = VariantOf<DrumGpuLaws>;

// A drum's step as plain values.
struct DrumModel {
  DrumGpuLaw law;
  CylinderWall wall;
  // Capped ends (drum.ends = "capped"): the caps, and y is not periodic.
  bool capped = false;
  EndCaps caps;
  // The domain (core/domain.hpp): [lo, hi), and which axes wrap.
  std::array<double, 3> lo{}, hi{};
  std::array<bool, 3> periodic{};
  double dt = 0.0;                      // integrator.dt
  std::array<double, 3> gravity{};      // as an acceleration
  double skin = 0.0;                    // neighbour-list skin
  double time = 0.0;                    // of the state below
  long step_count = 0;
  ParticleStore<3> p;  // the state, in the order the stepper keeps
};

// Advances a DrumModel's state on one backend.
class DrumStepper {
 public:
  virtual ~DrumStepper() = default;
  // n steps of the leapfrog (integrate/leapfrog.hpp): at the end the
  // velocities are those of the full step, as after Simulation::advance.
  virtual void advance(long n) = 0;
  // The state (x, v, w, f, tq) into p, which holds the model's particles in
  // the model's order.
  virtual void download(ParticleStore<3>& p) const = 0;
  virtual double time() const = 0;
  virtual long step_count() const = 0;
  virtual long builds() const = 0;             // neighbour-list builds so far
  virtual const char* backend() const = 0;     // "host" or "cuda"
};

// The kernels built by the host compiler, run as loops on the CPU (gpu/drum_host.cpp).
std::unique_ptr<DrumStepper> make_host_drum(const DrumModel& m);

#if defined(GRANULAR_HAVE_CUDA)
// The kernels built by nvcc, run on the first visible CUDA device (gpu/drum_cuda.cu).
std::unique_ptr<DrumStepper> make_cuda_drum(const DrumModel& m);
// Empty if a CUDA device is visible, else why not (one line).
std::string cuda_unavailable();
#endif

}  // namespace granular::gpu
