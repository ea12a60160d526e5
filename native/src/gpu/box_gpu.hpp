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
// simulation, gpu/box_model.hpp) and a BoxStepper that advances it, with the
// drum's interface (gpu/stepper.hpp) so that one driver
// (gpu/stepper_driver.hpp) runs either on the CPU engine's run loop.
#pragma once
#include <array>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "boundary/flat_box_walls.hpp"
#include "contact/laws.hpp"
#include "core/particles.hpp"
#include "core/type_list.hpp"
#include "gpu/stepper.hpp"
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
  // The longest move a particle may make in one step (Simulation::max_step_move:
  // half the smallest diameter, or the scene's speed limit times dt), the wall
  // particles' moves included; a step that moves one further stops the
  // stepper (StepUnstable).
  double max_step_move = std::numeric_limits<double>::infinity();
  // The state, in the order the stepper keeps, with Gear's scaled
  // derivatives in the aux columns (Gear5::start).
  ParticleStore<2> p;
  // Empty: a new start (the list is built from p.x). Otherwise a resumed one:
  // the positions the neighbour list was last built from (the list is
  // rebuilt from them, row for row the list in use). p.f, p.tq are the last
  // step's forces either way, used as they are.
  Column<Eigen::Vector2d> x_ref;  // Whether the stepper moves the particles in memory to the order of their
  // cells at each neighbour-list build (gpu/kernel_stepper.hpp): the same
  // results either way; off, memory keeps the order of p (for measuring
  // what the order is worth: granular bench --gpu-memory-order ids).
  bool reorder = true;
};

// Advances the state of one or several BoxModels (replicas: boxes of one
// scene with other seeds, side by side in the same arrays, each kernel
// launched once for all) on one backend (gpu/stepper.hpp): n steps of the
// models' integrator at a time, with Gear's aux columns downloaded where the
// store has them. The replicas share the integrator, its dt, the walls, the
// shaker and the domain (std::invalid_argument otherwise); their particle
// counts may differ.
using BoxStepper = Stepper<2>;

// The kernels built by the host compiler, run as loops on the CPU (gpu/box_host.cpp).
std::unique_ptr<BoxStepper> make_host_box(const BoxModel& m);
std::unique_ptr<BoxStepper> make_host_box(const std::vector<BoxModel>& replicas);

#if defined(GRANULAR_HAVE_CUDA)
// The kernels built by nvcc, run on the first visible CUDA device
// (gpu/box_cuda.cu; gpu/drum_gpu.hpp's cuda_unavailable says why not).
std::unique_ptr<BoxStepper> make_cuda_box(const BoxModel& m);
std::unique_ptr<BoxStepper> make_cuda_box(const std::vector<BoxModel>& replicas);
#endif

// The device memory replicas of a box need, as gpu/drum_gpu.hpp's
// device_bytes counts it (DeviceSizing; declared there): the particles and
// each replica's cells, and list columns for the densest packing of the
// smallest disks within reach, plus the box's own columns (the wall
// particles' anchors, Gear's scaled derivatives).
struct DeviceSizing;
DeviceSizing box_sizing(const std::vector<BoxModel>& replicas);

}  // namespace granular::gpu
