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
//   rebuild     if the largest displacement exceeds skin/2: the reference
//               positions renewed, particles sorted by the cell of their
//               reference position, each cell's range, then every particle
//               lists every neighbour within range + skin of the reference
//               positions (a full list, in the order of the cell stencil),
//               no pair of two wall particles
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
#include "integrate/gear.hpp"
#include "integrate/leapfrog.hpp"
#include "integrate/motion.hpp"

namespace granular::gpu {
inline namespace GRANULAR_EXEC_NS {

// The particles, structure of arrays: vector columns by component,
// x[a * n + i]; Gear's scaled derivatives r2..r5 (two components each) and
// phi0, phi2..phi5 of the angle (one each). Raw pointers into the stepper's
// DeviceArrays.
struct BoxArrays {
  double* x;
  double* v;
  double* w;
  double* f;
  double* t;
  const double* d;
  const double* inv_m;
  const double* inv_i;
  const std::int32_t* species;
  const double* anchor;  // wall particles' rest positions (ShakerMotion::anchor by id), by index
  double* r[4];          // r2, r3, r4, r5
  double* q[5];          // phi0, phi2, phi3, phi4, phi5
  double* x_ref;         // positions at the last list build
  double* disp2;         // squared displacement since then
  unsigned n;
};

// Particle i's side of the pair (i, j): the contact through the law's
// pair_lane, if the two are within the law's range; returns whether they are.
// The inputs are formed as the CPU pair loop forms them (dr = r_i - r_j, the
// box is not periodic; v = v_i - v_j).
template <class Law>
GRANULAR_HD bool box_pair_on_i(const Law& law, const BoxArrays& s, unsigned i, unsigned j, PairForce<2>& o) {
  const unsigned n = s.n;
  PairContact<2> c;
  for (int a = 0; a < 2; ++a) c.dr[a] = s.x[a * n + i] - s.x[a * n + j];
  c.r2 = c.dr[0] * c.dr[0] + c.dr[1] * c.dr[1];
  c.di = s.d[i];
  c.dj = s.d[j];
  const double rc = Law::range(c.di, c.dj);
  if (!(c.r2 < rc * rc)) return false;
  for (int a = 0; a < 2; ++a) c.v[a] = s.v[a * n + i] - s.v[a * n + j];
  c.wi[0] = s.w[i];
  c.wj[0] = s.w[j];
  c.ci = s.species[i];
  c.cj = s.species[j];
  c.inv_mi = s.inv_m[i];
  c.inv_mj = s.inv_m[j];
  law.pair_lane(c, o);
  return true;
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

// The leapfrog's stage 1 (Leapfrog::first_half): walls placed, every other
// particle kicked and drifted.
struct LeapfrogFirst {
  BoxArrays s;
  double dt;
  double g[2];
  Pose2 pose;
  double step_lim2;  // max_step_move squared

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    double step[2];
    if (s.species[i] == kWallSpecies) {
      place_wall(s, pose, i, step);
    } else {
      const double h = 0.5 * dt, inv_m = s.inv_m[i], hi = h * s.inv_i[i];
      for (int a = 0; a < 2; ++a) leapfrog_kick(h, s.f[a * n + i], inv_m, g[a], s.v[a * n + i]);
      leapfrog_spin_kick(hi, s.t[i], s.w[i]);
      for (int a = 0; a < 2; ++a) step[a] = leapfrog_drift(dt, s.v[a * n + i], s.x[a * n + i]);
    }
    note_displacement(s, i, step, step_lim2);
  }
};

// The leapfrog's stage 2 (Leapfrog::second_half): every particle but the
// wall's kicked.
struct LeapfrogSecond {
  BoxArrays s;
  double dt;
  double g[2];

  GRANULAR_HD void operator()(unsigned i) const {
    if (s.species[i] == kWallSpecies) return;
    const unsigned n = s.n;
    const double h = 0.5 * dt, inv_m = s.inv_m[i], hi = h * s.inv_i[i];
    for (int a = 0; a < 2; ++a) leapfrog_kick(h, s.f[a * n + i], inv_m, g[a], s.v[a * n + i]);
    leapfrog_spin_kick(hi, s.t[i], s.w[i]);
  }
};

// Gear's predictor (Gear5::first_half): walls placed, every other particle's
// coordinates and angle predicted.
struct GearPredict {
  BoxArrays s;
  double dt;
  Pose2 pose;
  double step_lim2;  // max_step_move squared

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    double step[2];
    if (s.species[i] == kWallSpecies) {
      place_wall(s, pose, i, step);
    } else {
      for (int a = 0; a < 2; ++a) {
        const unsigned k = a * n + i;
        step[a] = gear_predict(dt, s.x[k], s.v[k], s.r[0][k], s.r[1][k], s.r[2][k], s.r[3][k]);
      }
      gear_predict(dt, s.q[0][i], s.w[i], s.q[1][i], s.q[2][i], s.q[3][i], s.q[4][i]);
    }
    note_displacement(s, i, step, step_lim2);
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

// The cells of the (open) box: at least range + skin wide, so every listed
// pair lies in the same or an adjacent cell.
struct CellGrid2 {
  int n[2];
  double lo[2], width[2];

  // Particle coordinate x's cell along axis a; a particle outside the
  // domain belongs to the edge cell.
  GRANULAR_HD int coord(double x, int a) const {
    double q = std::floor((x - lo[a]) / width[a]);
    q = q >= 0.0 ? q : 0.0;  // and NaN to 0
    q = q <= n[a] - 1 ? q : n[a] - 1;
    return static_cast<int>(q);
  }
  GRANULAR_HD unsigned index(int q0, int q1) const {
    return static_cast<unsigned>(q1) * n[0] + static_cast<unsigned>(q0);
  }
  unsigned cells() const { return static_cast<unsigned>(n[0]) * n[1]; }
};

// The positions the list is built from (renew: the current ones, else the
// reference positions kept, as a resumed run's), each particle's cell of its
// reference position and its index (the values the sort carries).
struct BoxCellOf {
  BoxArrays s;
  CellGrid2 grid;
  bool renew;
  std::uint32_t* cell;
  std::uint32_t* index;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    int q[2];
    for (int a = 0; a < 2; ++a) {
      if (renew) s.x_ref[a * n + i] = s.x[a * n + i];
      q[a] = grid.coord(s.x_ref[a * n + i], a);
    }
    cell[i] = grid.index(q[0], q[1]);
    index[i] = i;
  }
};

// Every cell's range [start, end) in the sorted order (cells start empty).
struct BoxCellRanges {
  const std::uint32_t* sorted_cell;
  std::uint32_t* start;
  std::uint32_t* end;
  unsigned n;

  GRANULAR_HD void operator()(unsigned k) const {
    const std::uint32_t c = sorted_cell[k];
    if (k == 0 || sorted_cell[k - 1] != c) start[c] = k;
    if (k + 1 == n || sorted_cell[k + 1] != c) end[c] = k + 1;
  }
};

struct BoxClear {
  std::uint32_t* start;
  std::uint32_t* end;
  GRANULAR_HD void operator()(unsigned c) const { start[c] = end[c] = 0; }
};

// Particle i's row of the full list: every j != i within range + skin of the
// reference positions, from the 9 cells around i's (fewer at an edge), but
// no pair of two particles of the excluded species. Rows hold at most cap entries (column-major,
// nbr[m * n + i]); count[i] is the row's true length, and if any exceeds
// cap the caller enlarges the list and builds again.
template <class Law>
struct BoxListNeighbors {
  BoxArrays s;
  CellGrid2 grid;
  double skin;
  int exclude;
  const std::uint32_t* start;
  const std::uint32_t* end;
  const std::uint32_t* sorted;
  std::uint32_t* nbr;
  std::uint32_t* count;
  unsigned cap;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    const double xi[2] = {s.x_ref[i], s.x_ref[n + i]};
    const double di = s.d[i];
    const bool excluded = s.species[i] == exclude;
    int q[2];
    for (int a = 0; a < 2; ++a) q[a] = grid.coord(xi[a], a);
    unsigned m = 0;
    for (int c0 = q[0] > 0 ? q[0] - 1 : 0, e0 = q[0] < grid.n[0] - 1 ? q[0] + 1 : q[0]; c0 <= e0; ++c0)
      for (int c1 = q[1] > 0 ? q[1] - 1 : 0, e1 = q[1] < grid.n[1] - 1 ? q[1] + 1 : q[1]; c1 <= e1; ++c1) {
        const std::uint32_t c = grid.index(c0, c1);
        for (std::uint32_t k = start[c], ke = end[c]; k < ke; ++k) {
          const std::uint32_t j = sorted[k];
          if (j == i || (excluded && s.species[j] == exclude)) continue;
          const double dx = xi[0] - s.x_ref[j], dy = xi[1] - s.x_ref[n + j];
          const double r2 = dx * dx + dy * dy;
          const double rc = Law::range(di, s.d[j]) + skin;
          if (r2 < rc * rc) {
            if (m < cap) nbr[m * n + i] = j;
            ++m;
          }
        }
      }
    count[i] = m;
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
  const std::uint32_t* nbr;
  const std::uint32_t* count;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    double f[2] = {0.0, 0.0}, t = 0.0;
    if constexpr (Walls == BoxWalls::smooth) flat_walls_on_i(law, walls, s, i, f, t);
    for (std::uint32_t m = 0, me = count[i]; m < me; ++m) {
      PairForce<2> pf;
      if (!box_pair_on_i(law, s, i, nbr[m * n + i], pf)) continue;
      for (int a = 0; a < 2; ++a) f[a] += pf.f[a];
      t += pf.ti[0];
    }
    for (int a = 0; a < 2; ++a) s.f[a * n + i] = f[a];
    s.t[i] = t;
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
  const std::uint32_t* nbr;
  const std::uint32_t* count;
  double* out;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    // v - v is 0 for a finite v, NaN for an infinite or NaN one.
    double zero = (s.w[i] - s.w[i]);
    for (int a = 0; a < 2; ++a) zero += (s.x[a * n + i] - s.x[a * n + i]) + (s.v[a * n + i] - s.v[a * n + i]);
    if (!(zero == 0.0)) {
      out[i] = std::numeric_limits<double>::infinity();
      return;
    }
    double worst = -std::numeric_limits<double>::infinity();
    for (std::uint32_t m = 0, me = count[i]; m < me; ++m) {
      const unsigned j = nbr[m * n + i];
      const double dx = s.x[i] - s.x[j], dy = s.x[n + i] - s.x[n + j];
      const double r = std::sqrt(dx * dx + dy * dy);
      const double rc = Law::range(s.d[i], s.d[j]);
      const double ov = (rc - r) / rc;
      if (r < rc && ov > worst) worst = ov;
    }
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

// The stepper: the state in DeviceArrays and the step above, for one
// integrator and one kind of walls.
template <class Law, BoxIntegrator Integrator, BoxWalls Walls>
class BoxKernels final : public BoxStepper {
  static constexpr bool kGear = Integrator == BoxIntegrator::gear;

 public:
  BoxKernels(const Law& law, const BoxModel& m)
      : law_(law),
        shaker_(m.shaker),
        flat_(m.flat),
        n_(static_cast<unsigned>(m.p.size())),
        time_(m.time),
        steps_(m.step_count) {
    if (m.p.size() >= std::numeric_limits<std::uint32_t>::max())
      throw std::invalid_argument("GPU box: too many particles for 32-bit indices");
    if (kGear && (m.p.aux_v.size() != 4 || m.p.aux_a.size() != 5))
      throw std::invalid_argument("GPU box: Gear's scaled derivatives are missing from the state (Gear5::start)");
    dt_ = m.dt;
    c0_ = m.gear_c0;
    skin_ = m.skin;
    exclude_ = m.exclude_species;
    step_lim2_ = m.max_step_move * m.max_step_move;
    for (int a = 0; a < 2; ++a) g_[a] = m.gravity[a];
    upload(m.p);
    // Cells sized for the widest particle.
    double d_max = 0.0;
    for (double d : m.p.d) d_max = std::max(d_max, d);
    const double min_cell = Law::range(d_max, d_max) + skin_;
    for (int a = 0; a < 2; ++a) {
      const double len = m.hi[a] - m.lo[a];
      const int c = std::max(1, static_cast<int>(len / min_cell));
      grid_.n[a] = c;
      grid_.lo[a] = m.lo[a];
      grid_.width[a] = len / c;
    }
    if (grid_.cells() >= std::numeric_limits<std::uint32_t>::max() / 2)
      throw std::invalid_argument("GPU box: too many cells for 32-bit keys");
    end_bit_ = 1;
    while ((std::uint64_t{1} << end_bit_) < grid_.cells()) ++end_bit_;
    cell_start_.resize(grid_.cells());
    cell_end_.resize(grid_.cells());
    cell_.resize(n_);
    index_.resize(n_);
    sorted_cell_.resize(n_);
    sorted_.resize(n_);
    count_.resize(n_);
    disp2_.resize(n_);
    x_ref_.resize(2 * static_cast<std::size_t>(n_));
    // A resumed run's list is built from the positions the list in use was
    // built from; a new one's from the current positions.
    const bool resumed = !m.x_ref.empty();
    if (resumed) {
      if (m.x_ref.size() != m.p.size())
        throw std::invalid_argument("GPU box: the list's reference positions are not one per particle");
      upload_vectors(m.x_ref, x_ref_);
    }
    // The forces of the model's state are those the CPU engine computed
    // (Simulation::init, or the last step): the first stage reads them.
    build(!resumed);
    synchronize();
  }

  void advance(long steps) override {
    const double lim2 = 0.25 * skin_ * skin_;  // (skin/2)^2
    for (long k = 0; k < steps; ++k) {
      const double t_next = time_ + dt_;
      const auto b = pose_at(shaker_, t_next);  // once per step, as the CPU integrators
      const Pose2 pose{{b.dx[0], b.dx[1]}, {b.v[0], b.v[1]}};
      const BoxArrays s = arrays();
      if constexpr (kGear)
        for_each(n_, GearPredict{s, dt_, pose, step_lim2_});
      else
        for_each(n_, LeapfrogFirst{s, dt_, {g_[0], g_[1]}, pose, step_lim2_});
      const double moved2 = max_of(disp2_.data(), n_, 0.0, max_d_, scratch_);
      if (!(moved2 <= std::numeric_limits<double>::max())) {
        synchronize();
        throw StepUnstable(0);
      }
      if (moved2 > lim2) build(true);
      for_each(n_, BoxForces<Law, Walls>{law_, walls_at(t_next), s, nbr_.data(), count_.data()});
      if constexpr (kGear)
        for_each(n_, GearCorrect{s, dt_, c0_, {g_[0], g_[1]}});
      else
        for_each(n_, LeapfrogSecond{s, dt_, {g_[0], g_[1]}});
      time_ = t_next;
      ++steps_;
    }
    synchronize();
  }

  void download(ParticleStore<2>& p, int r) const override {
    if (r != 0) throw std::invalid_argument("GPU box: a stepper holds one box (replica 0)");
    if (p.size() != n_) throw std::invalid_argument("GPU box: download into a store of another size");
    download_vectors(x_, p.x);
    download_vectors(v_, p.v);
    download_vectors(f_, p.f);
    download_angles(w_, p.w);
    download_angles(t_, p.tq);
    if (kGear && p.aux_v.size() == 4 && p.aux_a.size() == 5) {
      for (int k = 0; k < 4; ++k) download_vectors(r_[k], p.aux_v[k]);
      for (int k = 0; k < 5; ++k) download_angles(q_[k], p.aux_a[k]);
    }
  }

  Column<Eigen::Vector2d> reference_positions(int r) const override {
    if (r != 0) throw std::invalid_argument("GPU box: a stepper holds one box (replica 0)");
    Column<Eigen::Vector2d> out(n_);
    download_vectors(x_ref_, out);
    return out;
  }

  std::vector<double> worst_overlap() override {
    health_.resize(n_);
    for_each(n_, BoxWorstOverlap<Law, Walls>{arrays(), walls_at(time_), nbr_.data(), count_.data(), health_.data()});
    return {max_of(health_.data(), n_, -std::numeric_limits<double>::infinity(), max_d_, scratch_)};
  }

  double time() const override { return time_; }
  long step_count() const override { return steps_; }
  long builds() const override { return builds_; }
  const char* backend() const override { return kBackend; }

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

  BoxArrays arrays() {
    BoxArrays s{x_.data(), v_.data(), w_.data(), f_.data(), t_.data(), d_.data(), inv_m_.data(), inv_i_.data(),
                species_.data(), anchor_.data(), {}, {}, x_ref_.data(), disp2_.data(), n_};
    for (int k = 0; k < 4; ++k) s.r[k] = r_[k].data();
    for (int k = 0; k < 5; ++k) s.q[k] = q_[k].data();
    return s;
  }

  // A column of the store into a component-major array, and back.
  static void upload_vectors(const Column<Eigen::Vector2d>& col, DeviceArray<double>& out) {
    const std::size_t n = col.size();
    std::vector<double> h(2 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (int a = 0; a < 2; ++a) h[a * n + i] = col[i][a];
    out.upload(h);
  }
  static void upload_angles(const Column<Ang<2>>& col, DeviceArray<double>& out) {
    std::vector<double> h(col.size());
    for (std::size_t i = 0; i < col.size(); ++i) h[i] = col[i][0];
    out.upload(h);
  }
  void download_vectors(const DeviceArray<double>& in, Column<Eigen::Vector2d>& col) const {
    const auto h = in.download();
    for (unsigned i = 0; i < n_; ++i)
      for (int a = 0; a < 2; ++a) col[i][a] = h[a * n_ + i];
  }
  void download_angles(const DeviceArray<double>& in, Column<Ang<2>>& col) const {
    const auto h = in.download();
    for (unsigned i = 0; i < n_; ++i) col[i][0] = h[i];
  }
  void upload(const ParticleStore<2>& p) {
    upload_vectors(p.x, x_);
    upload_vectors(p.v, v_);
    upload_vectors(p.f, f_);
    upload_angles(p.w, w_);
    upload_angles(p.tq, t_);
    d_.upload(p.d.data(), p.d.size());
    inv_m_.upload(p.inv_m.data(), p.inv_m.size());
    inv_i_.upload(p.inv_i.data(), p.inv_i.size());
    species_.upload(p.species.data(), p.species.size());
    // The wall particles' anchors, by index (the shaker keeps them by id).
    std::vector<double> anchor(2 * static_cast<std::size_t>(n_), 0.0);
    for (unsigned i = 0; i < n_; ++i) {
      if (p.species[i] != kWallSpecies) continue;
      const auto id = static_cast<std::size_t>(p.id[i]);
      if (id >= shaker_.anchor.size()) throw std::invalid_argument("GPU box: a wall particle without an anchor");
      for (int a = 0; a < 2; ++a) anchor[a * n_ + i] = shaker_.anchor[id][a];
    }
    anchor_.upload(anchor);
    if constexpr (kGear) {
      for (int k = 0; k < 4; ++k) upload_vectors(p.aux_v[k], r_[k]);
      for (int k = 0; k < 5; ++k) upload_angles(p.aux_a[k], q_[k]);
    }
  }

  // The cell sort and the full list, from the current positions (renew) or
  // the reference positions kept; the list grows until every row fits.
  void build(bool renew) {
    const BoxArrays s = arrays();
    for_each(n_, BoxCellOf{s, grid_, renew, cell_.data(), index_.data()});
    sort_pairs(cell_.data(), sorted_cell_.data(), index_.data(), sorted_.data(), n_, end_bit_, scratch_);
    for_each(grid_.cells(), BoxClear{cell_start_.data(), cell_end_.data()});
    for_each(n_, BoxCellRanges{sorted_cell_.data(), cell_start_.data(), cell_end_.data(), n_});
    while (true) {
      nbr_.resize(static_cast<std::size_t>(cap_) * n_);
      for_each(n_, BoxListNeighbors<Law>{s, grid_, skin_, exclude_, cell_start_.data(), cell_end_.data(),
                                         sorted_.data(), nbr_.data(), count_.data(), cap_});
      const std::uint32_t longest = max_of(count_.data(), n_, std::uint32_t{0}, max_count_, scratch_);
      if (longest <= cap_) break;
      cap_ = longest + longest / 4 + 8;
    }
    ++builds_;
  }

  Law law_;
  ShakerMotion<2> shaker_;
  FlatBoxWalls flat_;
  unsigned n_;
  double time_;
  long steps_;
  long builds_ = 0;
  double dt_ = 0.0, c0_ = 0.0, skin_ = 0.0, step_lim2_ = 0.0;
  double g_[2] = {0.0, 0.0};
  int exclude_ = -1;
  CellGrid2 grid_{};
  int end_bit_ = 1;
  unsigned cap_ = 16;  // list columns per particle
  DeviceArray<double> x_, v_, w_, f_, t_, d_, inv_m_, inv_i_, anchor_, x_ref_, disp2_, max_d_, health_;
  DeviceArray<double> r_[4], q_[5];
  DeviceArray<std::int32_t> species_;
  DeviceArray<std::uint32_t> cell_, index_, sorted_cell_, sorted_, cell_start_, cell_end_, nbr_, count_, max_count_;
  Scratch scratch_;
};

// A stepper for the model's law, integrator and walls, in this build.
inline std::unique_ptr<BoxStepper> make_box_stepper(const BoxModel& m) {
  return std::visit(
      [&](const auto& law) -> std::unique_ptr<BoxStepper> {
        using Law = std::decay_t<decltype(law)>;
        using I = BoxIntegrator;
        using W = BoxWalls;
        if (m.walls == W::smooth) {
          if (m.integrator == I::gear) return std::make_unique<BoxKernels<Law, I::gear, W::smooth>>(law, m);
          return std::make_unique<BoxKernels<Law, I::leapfrog, W::smooth>>(law, m);
        }
        if (m.integrator == I::gear) return std::make_unique<BoxKernels<Law, I::gear, W::particles>>(law, m);
        return std::make_unique<BoxKernels<Law, I::leapfrog, W::particles>>(law, m);
      },
      m.law);
}

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
