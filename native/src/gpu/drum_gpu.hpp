// The drum on the GPU path (docs/gpu.md): a drum's step (the rotating
// cylinder wall, periodic ends or end caps, the leapfrog, any registered 3D
// contact law) written once as kernels (gpu/drum_kernels.hpp) and built twice:
// by nvcc into CUDA kernels (gpu/drum_cuda.cu, with GRANULAR_HAVE_CUDA) and by
// the host compiler into plain loops (gpu/drum_host.cpp), which the tests
// check against the CPU engine on machines without a GPU.
//
// The interface is backend-neutral: a DrumModel (everything a step needs, as
// plain values, taken from a CPU drum simulation so that both start from the
// same scene path and the same state) and a DrumStepper that advances one or
// several of them (replicas: independent drums side by side in the same
// arrays, each kernel launched once for all).
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "boundary/cylinder_wall.hpp"
#include "boundary/end_caps.hpp"
#include "contact/laws.hpp"
#include "core/particles.hpp"
#include "core/type_list.hpp"
#include "gpu/stepper.hpp"

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
  // The longest move a particle may make in one step (Simulation::max_step_move:
  // half the smallest diameter, or the scene's speed limit times dt); a step
  // that moves one further stops the stepper (StepUnstable).
  double max_step_move = std::numeric_limits<double>::infinity();
  ParticleStore<3> p;  // the state; a particle's index is its id in the stepper
  // Empty: a new start (the list is built from p.x and the forces computed).
  // Otherwise a resumed one: the positions the neighbour list was last built
  // from (the list is rebuilt from them, row for row the list in use), and
  // p.f, p.tq are the last step's forces, used as they are.
  Column<Eigen::Vector3d> x_ref;  // Whether the stepper moves the particles in memory to the order of their
  // cells at each neighbour-list build (gpu/kernel_stepper.hpp): the same
  // results either way; off, memory keeps the order of p (for measuring
  // what the order is worth: granular bench --gpu-memory-order ids).
  bool reorder = true;
};

// Advances the state of one or several DrumModels (replicas) on one backend
// (gpu/stepper.hpp): n steps of the leapfrog (integrate/leapfrog.hpp) at a
// time; worst_overlap covers the listed pairs (the cylinder and the caps are
// not particles of the list).
using DrumStepper = Stepper<3>;

// The kernels built by the host compiler, run as loops on the CPU (gpu/drum_host.cpp).
std::unique_ptr<DrumStepper> make_host_drum(const DrumModel& m);
std::unique_ptr<DrumStepper> make_host_drum(const std::vector<DrumModel>& replicas);

#if defined(GRANULAR_HAVE_CUDA)
// The kernels built by nvcc, run on the first visible CUDA device (gpu/drum_cuda.cu).
std::unique_ptr<DrumStepper> make_cuda_drum(const std::vector<DrumModel>& replicas);
// Empty if a CUDA device is visible, else why not (one line).
std::string cuda_unavailable();
// The free memory of the first visible CUDA device (cudaMemGetInfo).
std::size_t cuda_free_bytes();
#endif

// The device memory a GPU drum needs, as the stepper (gpu/drum_kernels.hpp)
// allocates it: per particle the state (x, v, w, f, tq, d, 1/m, 1/I, the
// list's reference positions, two reductions' inputs: 23 doubles) and the
// spare column the particles are moved through (3 doubles), the species,
// replica, id, slot and cell-sort words (12 four-byte words) and the sort's
// temporary storage (cub's radix sort: about two keys and two values per
// particle), per cell of every replica its key and range (three words), and
// the full neighbour list, list_columns four-byte indices per particle.
struct DeviceSizing {
  std::size_t particles = 0;     // all replicas together
  std::size_t cells = 0;         // all replicas together
  std::size_t list_columns = 0;  // per particle
};
std::size_t device_bytes(const DeviceSizing& z);

// The list columns a drum's particles are expected to need: the particles
// whose centres lie within `reach` (the largest contact range plus the skin)
// of a particle's, in a random close packing (volume fraction 0.64) of the
// smallest diameter d_min, with the stepper's margin (a quarter more, and 8).
std::size_t expected_list_columns(double reach, double d_min);

// The cells of each replica's grid along each axis: at least the widest
// particle's range plus the skin wide; a periodic axis too short for three
// cells is one cell (neighbor/cell_list.hpp's rule; the stepper's grid).
inline std::array<int, 3> cell_counts(const DrumModel& m, double min_cell) {
  return cell_counts(m.lo, m.hi, m.periodic, min_cell);
}

// The sizing of replicas of m (each m.p.size() particles).
DeviceSizing drum_sizing(const DrumModel& m, int replicas);

}  // namespace granular::gpu
