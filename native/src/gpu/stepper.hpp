// The GPU path's stepper (docs/gpu.md), one interface for the drum
// (gpu/drum_gpu.hpp, DrumStepper: Stepper<3>) and the shaken box
// (gpu/box_gpu.hpp, BoxStepper: Stepper<2>): it advances the state of one or
// several models of a scene (replicas: independent systems side by side in
// the same arrays, each kernel launched once for all) on one backend, so that
// one driver (gpu/stepper_driver.hpp) runs either on the CPU engine's run
// loop. The replicas share everything but their particles (one scene,
// several seeds); each is stepped as it would be alone: its neighbour list is
// rebuilt when its own particles have moved far enough, from its own
// reference positions, so replica k gives the bits a stepper of replica k
// alone gives.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/particles.hpp"
#include "gpu/step_unstable.hpp"

namespace granular::gpu {

template <int Dim>
class Stepper {
 public:
  virtual ~Stepper() = default;
  // n steps of the model's integrator, as Simulation::advance takes them: at
  // the end the velocities are those of the full step.
  // Throws StepUnstable (the state as it describes) or std::runtime_error.
  virtual void advance(long n) = 0;
  // Replica r's state (x, v, w, f, tq, and the integrator's aux columns where
  // p has them) into p, which holds that model's particles in the model's
  // order.
  virtual void download(ParticleStore<Dim>& p, int r = 0) const = 0;
  // Replica r's positions at its last neighbour-list build (the checkpoint's x_ref).
  virtual Column<Vec<Dim>> reference_positions(int r = 0) const = 0;
  // Per replica, the largest overlap of a listed pair in range as a fraction
  // of its contact distance Law::range(d_i, d_j) (engine/health.hpp's
  // measure), and of a contact with the walls where a scene's walls are not
  // particles (the drum's list holds no wall; the box's smooth walls as a
  // fraction of R_i + r_w, FlatBoxWalls::deepest's); +infinity where a
  // position or velocity is not finite, -infinity where there is no contact.
  virtual std::vector<double> worst_overlap() = 0;
  // The particles' ids (their index in the models' order, replica after
  // replica) in the order they are held in memory.
  virtual std::vector<std::uint32_t> memory_order() const = 0;
  virtual int replicas() const = 0;
  virtual double time() const = 0;
  virtual long step_count() const = 0;
  virtual long builds() const = 0;          // neighbour-list builds so far (any replica's)
  virtual const char* backend() const = 0;  // "host" or "cuda"
};

// The cells of each replica's grid along each axis of the domain [lo, hi):
// at least min_cell (the widest particle's range plus the skin) wide; a
// periodic axis too short for three cells is one cell (neighbor/cell_list.hpp's
// rule; the steppers' grid).
template <std::size_t Dim>
std::array<int, Dim> cell_counts(const std::array<double, Dim>& lo, const std::array<double, Dim>& hi,
                                 const std::array<bool, Dim>& periodic, double min_cell) {
  std::array<int, Dim> c{};
  for (std::size_t a = 0; a < Dim; ++a) {
    const double len = hi[a] - lo[a];
    c[a] = std::max(1, static_cast<int>(len / min_cell));
    if (periodic[a] && c[a] < 3) c[a] = 1;
  }
  return c;
}

// The fields a model (DrumModel, BoxModel) takes from its CPU simulation as
// they are: the law, the integrator's dt and gravity, the domain [lo, hi),
// the skin, the time and step count, the move limit
// (Simulation::max_step_move) and the state.
template <class Model, class Sim>
void take_simulation(Model& m, const Sim& s) {
  m.law = s.law;
  m.dt = s.integrator.dt;
  for (std::size_t a = 0; a < m.lo.size(); ++a) {
    m.gravity[a] = s.integrator.gravity[a];
    m.lo[a] = s.domain.lo[a];
    m.hi[a] = s.domain.hi[a];
  }
  m.skin = s.skin;
  m.time = s.time;
  m.step_count = s.step_count;
  m.max_step_move = s.max_step_move();
  m.p = s.p;
}

}  // namespace granular::gpu
