// The shaken box on the GPU path (docs/gpu.md): Poeschel and Herrmann's
// (1995) box with walls of particles moved by the shaker (box.walls =
// "particles") or with smooth walls (box.walls = "smooth",
// boundary/flat_box_walls.hpp), under every registered box law, with Gear's predictor-
// corrector or the leapfrog, written once as kernels (gpu/box_kernels.hpp)
// and built twice: by nvcc into CUDA kernels (gpu/box_cuda.cu, with
// GRANULAR_HAVE_CUDA) and by the host compiler into plain loops
// (gpu/box_host.cpp), which the tests check against the CPU engine on
// machines without a GPU.
//
// The interface is backend-neutral, as the drum's (gpu/drum_gpu.hpp): a
// BoxModel (everything a step needs, as plain values, taken from a CPU box
// simulation, gpu/box_model.hpp) and a BoxStepper that advances it.
#pragma once
#include <array>
#include <memory>
#include <string>

#include "boundary/flat_box_walls.hpp"
#include "contact/laws.hpp"
#include "core/particles.hpp"
#include "core/type_list.hpp"
#include "integrate/motion.hpp"

namespace granular {
struct BoxScene;  // scene/box_scene.hpp: not needed here but as the laws' source
}

namespace granular::gpu {

// The laws the GPU box runs: every registered law the box can use (the CPU
// box's, engine/box.hpp's BoxLaws; gpu/box_model.cpp checks that the two
// lists agree).
using BoxGpuLaws = BoxSceneLaws<BoxScene>;
using BoxGpuLaw = VariantOf<BoxGpuLaws>;

// integrator.kind: Gear's predictor-corrector (integrate/gear.hpp) or the
// leapfrog (integrate/leapfrog.hpp).
enum class BoxIntegrator { gear, leapfrog };

// box.walls: smooth walls (boundary/flat_box_walls.hpp) or walls of particles
// (the paper's: particles of species kWallSpecies driven by the shaker).
enum class BoxWalls { smooth, particles };

// A shaken box's step as plain values.
struct BoxModel {
  BoxGpuLaw law;
  BoxIntegrator integrator = BoxIntegrator::leapfrog;
  double dt = 0.0;            // integrator.dt
  double gear_c0 = 0.0;       // Gear5::c0 (unused by the leapfrog)
  std::array<double, 2> gravity{};  // as an acceleration
  // The domain (core/domain.hpp, not periodic): [lo, hi).
  std::array<double, 2> lo{}, hi{};
  double skin = 0.0;          // neighbour-list skin
  // Pairs with both particles of this species are not listed (the wall
  // particles, Simulation::exclude_species); -1: none.
  int exclude_species = -1;
  // y_box(t): the shaker places the particles of species kWallSpecies at
  // their anchors (by id) displaced by it.
  ShakerMotion<2> shaker;
  // Smooth walls: `flat`, moving with `shaker`, and no wall particles.
  BoxWalls walls = BoxWalls::particles;
  FlatBoxWalls flat;
  double time = 0.0;  // of the state below
  long step_count = 0;
  // The state, in the order the stepper keeps, with Gear's scaled
  // derivatives in the aux columns (Gear5::start).
  ParticleStore<2> p;
};

// Advances a BoxModel's state on one backend.
class BoxStepper {
 public:
  virtual ~BoxStepper() = default;
  // n steps of the model's integrator, as Simulation::advance takes them.
  virtual void advance(long n) = 0;
  // The state (x, v, w, f, tq, and Gear's aux columns where p has them) into
  // p, which holds the model's particles in the model's order.
  virtual void download(ParticleStore<2>& p) const = 0;
  virtual double time() const = 0;
  virtual long step_count() const = 0;
  virtual long builds() const = 0;          // neighbour-list builds so far
  virtual const char* backend() const = 0;  // "host" or "cuda"
};

// The kernels built by the host compiler, run as loops on the CPU (gpu/box_host.cpp).
std::unique_ptr<BoxStepper> make_host_box(const BoxModel& m);

#if defined(GRANULAR_HAVE_CUDA)
// The kernels built by nvcc, run on the first visible CUDA device
// (gpu/box_cuda.cu; gpu/drum_gpu.hpp's cuda_unavailable says why not).
std::unique_ptr<BoxStepper> make_cuda_box(const BoxModel& m);
#endif

}  // namespace granular::gpu
