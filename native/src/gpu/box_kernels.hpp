// The shaken box's step as kernels, one source for both builds
// (gpu/exec.hpp): nvcc makes them CUDA kernels (gpu/box_cuda.cu), the host
// compiler plain loops (gpu/box_host.cpp). As the drum's
// (gpu/drum_kernels.hpp): every kernel is a functor run once per particle,
// and every particle's thread writes only that particle's entries, so the
// sums do not depend on scheduling and the two builds evaluate the same
// operations in the same order.
//
// The step, as Simulation::advance (engine/simulation.hpp) takes it for the
// box with walls of particles (engine/box.hpp, ParticleWallBoxOf) or smooth
// walls (SmoothBoxOf):
//
//   stage 1     wall particles placed at their anchors displaced by the
//               shaker's pose at the end of the step (ShakerMotion::place,
//               the pose evaluated once per step on the host); every other
//               particle: Gear's predictor (gear_predict) or the leapfrog's
//               kick and drift (leapfrog_kick, leapfrog_drift); the squared
//               displacement since the last list build, or +infinity where
//               the step's move exceeds max_step_move or is not finite
//               (Simulation's stability test: the stepper stops, StepUnstable)
//   rebuild     for each replica whose largest displacement exceeds
//               skin/2: its reference positions renewed; then particles
//               sorted by the cell of their reference position (the cells
//               keyed by replica), each cell's range, then every particle
//               lists every neighbour of its replica within range + skin of
//               the reference positions (a full list, in the order of the
//               cell stencil), no pair of two wall particles
//               (gpu/neighbor_kernels.hpp, the drum's too)
//   forces      each particle: with smooth walls, the walls' contacts
//               (flat_box_offsets, the walls at the end of the step); then
//               its side of each listed pair in range through the law's
//               pair_lane (Eqs. (1)-(6) of contact/poeschel_herrmann.hpp, or
//               contact/viscel.hpp), summed in list order
//   stage 2     every particle but the wall's: Gear's corrector
//               (gear_correct) or the leapfrog's kick
//
// The physics is the law's lane function, the smooth walls' geometry and the
// integrators' updates (integrate/gear.hpp, integrate/leapfrog.hpp), called
// here, not copied. The
// CPU engine sums a particle's contacts in its half list's order, this path
// in its full list's, so the two agree to rounding, not bitwise
// (tests/native/test_gpu_box.cpp).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "boundary/flat_box_walls.hpp"
#include "contact/lane.hpp"
#include "gpu/box_gpu.hpp"
#include "gpu/exec.hpp"
#include "gpu/kernel_stepper.hpp"
#include "gpu/neighbor_kernels.hpp"
#include "integrate/gear.hpp"
#include "integrate/leapfrog.hpp"
#include "integrate/motion.hpp"

namespace granular::gpu {
inline namespace GRANULAR_EXEC_NS {

// The particles (ParticleArrays, the spin and torque one component each),
// the wall particles' anchors, Gear's scaled derivatives r2..r5 (two
// components each) and phi0, phi2..phi5 of the angle (one each), and the
// list's reference positions and displacements.
struct BoxArrays : ParticleArrays {
  const double* anchor;  // wall particles' rest positions (ShakerMotion::anchor by id), by index
  double* r[4];          // r2, r3, r4, r5
  double* q[5];          // phi0, phi2, phi3, phi4, phi5
  double* x_ref;         // positions at the last list build
  double* disp2;         // squared displacement since then
  unsigned n;
};

// Particle i's side of the pair (i, j) (pair_side; the box is not periodic).
template <class Law>
GRANULAR_HD bool box_pair_on_i(const Law& law, const BoxArrays& s, unsigned i, unsigned j, PairForce<2>& o) {
  return pair_side(law, OpenDomain<2>{}, s, s.n, i, j, o);
}

// The smooth walls at one time (FlatBoxWalls::apply's values at y_box(t)):
// floor_c = y_box - r_w, top_c = y_box + y_top, xc = W/2 + r_w, the walls'
// velocity dy_box/dt, the virtual wall particle's diameter 2 r_w and inverse
// mass.
struct FlatWalls2 {
  double floor_c, top_c, xc, vy, d_wall, inv_m;
};

// The smooth walls' contacts with particle i through the law's pair_lane
// (FlatBoxWalls::touch: the grain against a virtual wall particle), added to
// f and t in the order floor, left wall, right wall.
template <class Law>
GRANULAR_HD void flat_walls_on_i(const Law& law, const FlatWalls2& fw, const BoxArrays& s, unsigned i,
                                 double (&f)[2], double& t) {
  const unsigned n = s.n;
  const double di = s.d[i], rc = Law::range(di, fw.d_wall);
  flat_box_offsets(s.x[i], s.x[n + i], fw.floor_c, fw.top_c, fw.xc, [&](double dx, double dy) {
    PairContact<2> c;
    c.dr[0] = dx;
    c.dr[1] = dy;
    c.r2 = dx * dx + dy * dy;
    if (c.r2 >= rc * rc) return;
    c.di = di;
    c.dj = fw.d_wall;
    c.v[0] = s.v[i] - 0.0;  // v_i - v_j, v_j = (0, dy_box/dt)
    c.v[1] = s.v[n + i] - fw.vy;
    c.wi[0] = s.w[i];
    c.wj[0] = 0.0;
    c.ci = s.species[i];
    c.cj = kWallSpecies;
    c.inv_mi = s.inv_m[i];
    c.inv_mj = fw.inv_m;
    PairForce<2> o;
    law.pair_lane(c, o);
    for (int a = 0; a < 2; ++a) f[a] += o.f[a];
    t += o.ti[0];
  });
}

// The shaker's pose at one time (ShakerMotion::Pose), as plain values.
struct Pose2 {
  double dx[2], v[2];
};

// A wall particle placed by the pose (ShakerMotion::place): x = anchor + dx,
// v = the box's velocity, w = 0; its move in this step into step
// (place_if_wall's: the new position less the old).
GRANULAR_HD void place_wall(const BoxArrays& s, const Pose2& pose, unsigned i, double (&step)[2]) {
  const unsigned n = s.n;
  for (int a = 0; a < 2; ++a) {
    const double old = s.x[a * n + i];
    s.x[a * n + i] = s.anchor[a * n + i] + pose.dx[a];
    step[a] = s.x[a * n + i] - old;
    s.v[a * n + i] = pose.v[a];
  }
  s.w[i] = 0.0;
}

// The squared displacement of particle i since the list's build, or
// +infinity where this step's move (step) is longer than max_step_move
// (step_lim2 = its square) or anything is not finite (Simulation's stability
// test), which the stepper reports.
GRANULAR_HD void note_displacement(const BoxArrays& s, unsigned i, const double (&step)[2], double step_lim2) {
  const unsigned n = s.n;
  const double dx = s.x[i] - s.x_ref[i], dy = s.x[n + i] - s.x_ref[n + i];
  const double d2 = dx * dx + dy * dy;
  const double s2 = step[0] * step[0] + step[1] * step[1];
  const bool fine = d2 <= std::numeric_limits<double>::max() && s2 <= step_lim2;
  s.disp2[i] = fine ? d2 : std::numeric_limits<double>::infinity();
}

// Half a step's kick of particle i from its forces (Leapfrog::kick:
// leapfrog_kick and leapfrog_spin_kick).
GRANULAR_HD void leapfrog_half_kick(const BoxArrays& s, double dt, const double (&g)[2], unsigned i) {
  const unsigned n = s.n;
  const double h = 0.5 * dt, inv_m = s.inv_m[i], hi = h * s.inv_i[i];
  for (int a = 0; a < 2; ++a) leapfrog_kick(h, s.f[a * n + i], inv_m, g[a], s.v[a * n + i]);
  leapfrog_spin_kick(hi, s.t[i], s.w[i]);
}

// Stage 1 (Leapfrog::first_half, Gear5::first_half): wall particles placed
// by the pose, every other particle moved by the integrator's Move
// (move(s, i, step): its update, and the position's change into step); then
// the displacement noted.
template <class Move>
struct FirstStage {
  BoxArrays s;
  Move move;
  Pose2 pose;
  double step_lim2;  // max_step_move squared

  GRANULAR_HD void operator()(unsigned i) const {
    double step[2];
    if (s.species[i] == kWallSpecies)
      place_wall(s, pose, i, step);
    else
      move(s, i, step);
    note_displacement(s, i, step, step_lim2);
  }
};

// The leapfrog's move in stage 1: a kick and the drift.
struct LeapfrogMove {
  double dt;
  double g[2];

  GRANULAR_HD void operator()(const BoxArrays& s, unsigned i, double (&step)[2]) const {
    const unsigned n = s.n;
    leapfrog_half_kick(s, dt, g, i);
    for (int a = 0; a < 2; ++a) step[a] = leapfrog_drift(dt, s.v[a * n + i], s.x[a * n + i]);
  }
};

// The leapfrog's stage 2 (Leapfrog::second_half): every particle but the
// wall's kicked.
struct LeapfrogSecond {
  BoxArrays s;
  double dt;
  double g[2];

  GRANULAR_HD void operator()(unsigned i) const {
    if (s.species[i] != kWallSpecies) leapfrog_half_kick(s, dt, g, i);
  }
};

// Gear's predictor in stage 1: the coordinates and the angle predicted.
struct GearMove {
  double dt;

  GRANULAR_HD void operator()(const BoxArrays& s, unsigned i, double (&step)[2]) const {
    const unsigned n = s.n;
    for (int a = 0; a < 2; ++a) {
      const unsigned k = a * n + i;
      step[a] = gear_predict(dt, s.x[k], s.v[k], s.r[0][k], s.r[1][k], s.r[2][k], s.r[3][k]);
    }
    gear_predict(dt, s.q[0][i], s.w[i], s.q[1][i], s.q[2][i], s.q[3][i], s.q[4][i]);
  }
};

// Gear's corrector (Gear5::second_half) on every particle but the wall's,
// from the forces at the predicted state.
struct GearCorrect {
  BoxArrays s;
  double dt, c0;
  double g[2];

  GRANULAR_HD void operator()(unsigned i) const {
    if (s.species[i] == kWallSpecies) return;
    const unsigned n = s.n;
    const double h2 = 0.5 * dt * dt, inv_m = s.inv_m[i], hi = h2 * s.inv_i[i];
    for (int a = 0; a < 2; ++a) {
      const unsigned k = a * n + i;
      gear_correct(c0, dt, h2 * (s.f[k] * inv_m + g[a]), s.x[k], s.v[k], s.r[0][k], s.r[1][k], s.r[2][k],
                   s.r[3][k]);
    }
    gear_correct(c0, dt, hi * s.t[i], s.q[0][i], s.w[i], s.q[1][i], s.q[2][i], s.q[3][i], s.q[4][i]);
  }
};

// Particle i's force and torque: the smooth walls' contacts (smooth walls),
// then its side of every listed pair in range, in list order (walls of
// particles are particles in the list).
template <class Law, BoxWalls Walls>
struct BoxForces {
  Law law;
  FlatWalls2 walls;
  BoxArrays s;
  ListRows list;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    double f[2] = {0.0, 0.0}, t[1] = {0.0};
    if constexpr (Walls == BoxWalls::smooth) flat_walls_on_i(law, walls, s, i, f, t[0]);
    add_listed_pairs(law, OpenDomain<2>{}, s, n, list, i, f, t);
    store_force(s, n, i, f, t);
  }
};

// Particle i's worst overlap, as a fraction of the contact distance: over its
// listed pairs in range, (range - r) / range with r the centres' distance
// (engine/health.hpp's measure), and with smooth walls over its contacts
// with the walls, (R_i + r_w - r) / (R_i + r_w) (FlatBoxWalls::deepest's);
// -infinity without one, +infinity if its position or velocity is not finite.
template <class Law, BoxWalls Walls>
struct BoxWorstOverlap {
  BoxArrays s;
  FlatWalls2 walls;
  ListRows list;
  double* out;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    if (!finite_motion<2, 1>(s.x, s.v, s.w, n, i)) {
      out[i] = std::numeric_limits<double>::infinity();
      return;
    }
    double worst = worst_listed_overlap<Law, 2>(s.x, s.d, n, OpenDomain<2>{}, list, i);
    if constexpr (Walls == BoxWalls::smooth) {
      if (s.species[i] != kWallSpecies) {
        const double rc = 0.5 * s.d[i] + 0.5 * walls.d_wall;
        flat_box_offsets(s.x[i], s.x[n + i], walls.floor_c, walls.top_c, walls.xc, [&](double dx, double dy) {
          const double ov = (rc - std::sqrt(dx * dx + dy * dy)) / rc;
          if (ov > 0.0 && ov > worst) worst = ov;
        });
      }
    }
    out[i] = worst;
  }
};

// Whether two shakers move the box alike (their anchors aside).
inline bool same_shaking(const ShakerMotion<2>& a, const ShakerMotion<2>& b) {
  return a.amplitude == b.amplitude && a.f0 == b.f0 && a.f1 == b.f1 && a.start == b.start &&
         a.ramp_start == b.ramp_start && a.ramp_time == b.ramp_time && a.startup_cycles == b.startup_cycles;
}

// Whether two boxes' smooth walls are alike.
inline bool same_flat_walls(const FlatBoxWalls& a, const FlatBoxWalls& b) {
  return a.half_width == b.half_width && a.wall_radius == b.wall_radius && a.wall_inv_mass == b.wall_inv_mass &&
         a.side_top == b.side_top && same_shaking(a.shaker, b.shaker);
}

// The stepper: the state of one or several boxes (replicas: one scene, other
// seeds; gpu/kernel_stepper.hpp) and the step above, for one integrator and
// one kind of walls. The replicas share the time, so one shaker pose and one
// position of the smooth walls a step serve them all; each replica's wall
// particles have their own anchors, each its own list, rebuilt when its own
// particles have moved far enough, in cells keyed by replica.
template <class Law, BoxIntegrator Integrator, BoxWalls Walls>
class BoxKernels final : public KernelStepper<2> {
  static constexpr bool kGear = Integrator == BoxIntegrator::gear;

 public:
  BoxKernels(const Law& law, const std::vector<BoxModel>& ms)
      : KernelStepper<2>("GPU box", pointers(ms)), law_(law), shaker_(ms.front().shaker), flat_(ms.front().flat) {
    const BoxModel& m = ms.front();
    for (const BoxModel& r : ms) {
      if (r.integrator != Integrator || r.walls != Walls || r.dt != m.dt || r.gear_c0 != m.gear_c0 ||
          r.gravity != m.gravity || r.lo != m.lo || r.hi != m.hi || r.skin != m.skin ||
          r.exclude_species != m.exclude_species || r.law.index() != m.law.index() ||
          !same_shaking(r.shaker, m.shaker) || (Walls == BoxWalls::smooth && !same_flat_walls(r.flat, m.flat)))
        throw std::invalid_argument(
            "GPU box: replicas must share the integrator, its dt, the walls, the shaker and the domain");
      if (kGear && (r.p.aux_v.size() != 4 || r.p.aux_a.size() != 5))
        throw std::invalid_argument("GPU box: Gear's scaled derivatives are missing from the state (Gear5::start)");
    }
    c0_ = m.gear_c0;
    exclude_ = m.exclude_species;
    upload(ms);
    // Each replica's cells sized for its widest particle.
    reserve_list<Law>(m.lo, m.hi, {}, 16);
    // The forces of the model's state are those the CPU engine computed
    // (Simulation::init, or the last step): the first stage reads them. A
    // resumed run's list is built from the positions the list in use was
    // built from; a new one's from the current positions.
    build<Law>(OpenDomain<2>{}, pairs());
    synchronize();
  }

  // Each step's second stage and the next step's first run as one launch
  // (then()); the last step's second stage alone.
  void advance(long steps) override {
    if (steps <= 0) return;
    const BoxArrays s = arrays();
    for_each(n_, first_stage(s, time_ + dt_));
    for (long k = 0; k < steps; ++k) {
      const double t_next = time_ + dt_;
      if (must_rebuild()) build<Law>(OpenDomain<2>{}, pairs());
      for_each(n_, BoxForces<Law, Walls>{law_, walls_at(t_next), s, rows()});
      if (k + 1 < steps)
        for_each(n_, then(second_stage(s), first_stage(s, t_next + dt_)));
      else
        for_each(n_, second_stage(s));
      time_ = t_next;
      ++steps_;
    }
    synchronize();
  }

  void download(ParticleStore<2>& p, int r) const override {
    KernelStepper<2>::download(p, r);
    if (kGear && p.aux_v.size() == 4 && p.aux_a.size() == 5) {
      const unsigned off = offset(r);
      const auto slot = slot_of_.download();
      for (int k = 0; k < 4; ++k) download_column(r_[k], off, slot, p.aux_v[k]);
      for (int k = 0; k < 5; ++k) download_column(q_[k], off, slot, p.aux_a[k]);
    }
  }

  std::vector<double> worst_overlap() override {
    for_each(n_, BoxWorstOverlap<Law, Walls>{arrays(), walls_at(time_), rows(), health()});
    return worst_of_health();
  }

 private:
  // The smooth walls at time t (FlatBoxWalls::apply), evaluated on the host.
  FlatWalls2 walls_at(double t) const {
    FlatWalls2 w{};
    if constexpr (Walls == BoxWalls::smooth) {
      const double yb = flat_.shaker.y(t);
      w.floor_c = yb - flat_.wall_radius;
      w.top_c = yb + flat_.side_top;
      w.xc = flat_.half_width + flat_.wall_radius;
      w.vy = flat_.shaker.vy(t);
      w.d_wall = 2.0 * flat_.wall_radius;
      w.inv_m = flat_.wall_inv_mass;
    }
    return w;
  }

  static std::vector<const BoxModel*> pointers(const std::vector<BoxModel>& ms) {
    if (ms.empty()) throw std::invalid_argument("GPU box: no replica to step");
    std::vector<const BoxModel*> out;
    for (const BoxModel& m : ms) out.push_back(&m);
    return out;
  }

  // Stage 1 of the step that ends at t_next: the shaker's pose at t_next,
  // evaluated once per step on the host, as the CPU integrators do.
  auto first_stage(const BoxArrays& s, double t_next) const {
    const auto b = pose_at(shaker_, t_next);
    const Pose2 pose{{b.dx[0], b.dx[1]}, {b.v[0], b.v[1]}};
    if constexpr (kGear)
      return FirstStage<GearMove>{s, {dt_}, pose, step_lim2_};
    else
      return FirstStage<LeapfrogMove>{s, {dt_, {g_[0], g_[1]}}, pose, step_lim2_};
  }
  // Stage 2.
  auto second_stage(const BoxArrays& s) const {
    if constexpr (kGear)
      return GearCorrect{s, dt_, c0_, {g_[0], g_[1]}};
    else
      return LeapfrogSecond{s, dt_, {g_[0], g_[1]}};
  }

  // The list's pairs: none of two wall particles.
  NoPairWithinSpecies pairs() const { return {species_.data(), exclude_}; }

  BoxArrays arrays() {
    BoxArrays s{x_.data(), v_.data(), w_.data(), f_.data(), t_.data(), d_.data(), inv_m_.data(), inv_i_.data(),
                species_.data(), anchor_.data(), {}, {}, x_ref_.data(), disp2_.data(), n_};
    for (int k = 0; k < 4; ++k) s.r[k] = r_[k].data();
    for (int k = 0; k < 5; ++k) s.q[k] = q_[k].data();
    return s;
  }

  // The wall particles' anchors, by index (each replica's shaker keeps its
  // own by id), and Gear's scaled derivatives.
  void upload(const std::vector<BoxModel>& ms) {
    std::vector<double> anchor(2 * static_cast<std::size_t>(n_), 0.0);
    for (unsigned r = 0; r < k_; ++r) {
      const ParticleStore<2>& p = ms[r].p;
      const auto& anchors = ms[r].shaker.anchor;
      for (unsigned i = 0; i < p.size(); ++i) {
        if (p.species[i] != kWallSpecies) continue;
        const auto id = static_cast<std::size_t>(p.id[i]);
        if (id >= anchors.size()) throw std::invalid_argument("GPU box: a wall particle without an anchor");
        for (int a = 0; a < 2; ++a) anchor[a * n_ + offsets_[r] + i] = anchors[id][a];
      }
    }
    anchor_.upload(anchor);
    moved_with_particles(anchor_, 2);
    if constexpr (kGear) {
      for (int k = 0; k < 4; ++k) {
        std::vector<const Column<ParticleStore<2>::V>*> cols;
        for (const BoxModel& m : ms) cols.push_back(&m.p.aux_v[k]);
        upload_column(cols, r_[k]);
      }
      for (int k = 0; k < 5; ++k) {
        std::vector<const Column<ParticleStore<2>::A>*> cols;
        for (const BoxModel& m : ms) cols.push_back(&m.p.aux_a[k]);
        upload_column(cols, q_[k]);
      }
      for (auto& r : r_) moved_with_particles(r, 2);
      for (auto& q : q_) moved_with_particles(q, 1);
    }
  }

  Law law_;
  ShakerMotion<2> shaker_;
  FlatBoxWalls flat_;
  double c0_ = 0.0;
  int exclude_ = -1;
  DeviceArray<double> anchor_;
  DeviceArray<double> r_[4], q_[5];
};

// A stepper for the replicas' law, integrator and walls (the first's: the
// replicas are one scene), in this build.
inline std::unique_ptr<BoxStepper> make_box_stepper(const std::vector<BoxModel>& ms) {
  if (ms.empty()) throw std::invalid_argument("GPU box: no replica to step");
  const BoxModel& m = ms.front();
  return std::visit(
      [&](const auto& law) -> std::unique_ptr<BoxStepper> {
        using Law = std::decay_t<decltype(law)>;
        using I = BoxIntegrator;
        using W = BoxWalls;
        if (m.walls == W::smooth) {
          if (m.integrator == I::gear) return std::make_unique<BoxKernels<Law, I::gear, W::smooth>>(law, ms);
          return std::make_unique<BoxKernels<Law, I::leapfrog, W::smooth>>(law, ms);
        }
        if (m.integrator == I::gear) return std::make_unique<BoxKernels<Law, I::gear, W::particles>>(law, ms);
        return std::make_unique<BoxKernels<Law, I::leapfrog, W::particles>>(law, ms);
      },
      m.law);
}

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
