// The drum's step as kernels, one source for both builds
// (gpu/exec.hpp): nvcc makes them CUDA kernels (gpu/drum_cuda.cu), the host
// compiler plain loops (gpu/drum_host.cpp). Every kernel is a functor run
// once per particle, and every particle's thread writes only that particle's
// entries: no atomics, so the sums do not depend on scheduling, and the two
// builds evaluate the same operations in the same order.
//
// The step, as Simulation::advance (engine/simulation.hpp) takes it with
// Leapfrog<3> (integrate/leapfrog.hpp), CylinderWall, and PeriodicAxes or
// EndCaps:
//
//   stage 1     v += (dt/2) a;  r += dt v, wrapped along a periodic axis;
//               the squared displacement since the last list build, and
//               whether this step's move stayed within max_step_move
//   rebuild     for each replica whose largest displacement exceeds skin/2,
//               the reference positions are set to the current ones; then
//               particles are sorted by cell of their reference position
//               (sort_pairs, the cells keyed by replica), each cell's range
//               in the sorted order, and every particle lists every
//               neighbour of its replica within range + skin of the
//               reference positions (a full list, in the order of the cell
//               stencil): a replica's list depends on its own reference
//               positions only
//   forces      each particle: the cylinder's contact through the law's
//               wall_lane (the wall's geometry from CylinderWall::geometry),
//               with capped ends the caps' (EndCaps::geometry), then its
//               side of each listed pair in range through the law's
//               pair_lane, summed in list order (each pair is evaluated
//               from both sides)
//   stage 2     v += (dt/2) a
//
// The physics is the contact law's lane functions (contact/lane.hpp), the
// walls' geometry and the leapfrog's updates (leapfrog_kick, leapfrog_drift),
// called here, not copied. The CPU engine sums a particle's contacts in its
// half list's order, this path in its full list's, so the two agree to
// rounding, not bitwise
// (tests/native/test_gpu_drum.cpp).
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

#include "contact/lane.hpp"
#include "gpu/drum_gpu.hpp"
#include "gpu/exec.hpp"
#include "integrate/leapfrog.hpp"

namespace granular::gpu {
inline namespace GRANULAR_EXEC_NS {

// The domain as plain values, with core/domain.hpp's arithmetic: inv_len is
// 0 on the axes that do not wrap, so that there both operations are the
// identity.
struct Box {
  double lo[3], len[3], inv_len[3];

  // The minimum image of a separation (Domain::min_image).
  GRANULAR_HD void min_image(double (&dr)[3]) const {
    for (int a = 0; a < 3; ++a) dr[a] -= len[a] * std::nearbyint(dr[a] * inv_len[a]);
  }
  // A coordinate back into [lo, lo + len) (Domain::wrapped).
  GRANULAR_HD double wrapped(double x, int a) const { return x - len[a] * std::floor((x - lo[a]) * inv_len[a]); }
};

// The particles, structure of arrays: vector columns by component,
// x[a * n + i]. Raw pointers into the stepper's DeviceArrays.
struct DrumArrays {
  double* x;
  double* v;
  double* w;
  double* f;
  double* t;
  const double* d;
  const double* inv_m;
  const double* inv_i;
  const std::int32_t* species;
  double* x_ref;  // positions at the last list build
  double* disp2;  // squared displacement since then (+infinity: an unstable step)
  unsigned n;
};

// Particle i's side of the pair (i, j): the contact through the law's
// pair_lane, if the two are within the law's range; returns whether they are.
// The inputs are formed as the CPU pair loop forms them (dr = r_i - r_j after
// minimum image, v = v_i - v_j).
template <class Law>
GRANULAR_HD bool pair_on_i(const Law& law, const Box& box, const DrumArrays& s, unsigned i, unsigned j,
                           PairForce<3>& o) {
  const unsigned n = s.n;
  PairContact<3> c;
  for (int a = 0; a < 3; ++a) c.dr[a] = s.x[a * n + i] - s.x[a * n + j];
  box.min_image(c.dr);
  c.r2 = c.dr[0] * c.dr[0] + c.dr[1] * c.dr[1] + c.dr[2] * c.dr[2];
  c.di = s.d[i];
  c.dj = s.d[j];
  const double rc = Law::range(c.di, c.dj);
  if (!(c.r2 < rc * rc)) return false;
  for (int a = 0; a < 3; ++a) {
    c.v[a] = s.v[a * n + i] - s.v[a * n + j];
    c.wi[a] = s.w[a * n + i];
    c.wj[a] = s.w[a * n + j];
  }
  c.ci = s.species[i];
  c.cj = s.species[j];
  c.inv_mi = s.inv_m[i];
  c.inv_mj = s.inv_m[j];
  law.pair_lane(c, o);
  return true;
}

// The cylinder's contact with particle i through the law's wall_lane, if the
// particle is within reach (CylinderWall::in_reach); returns whether it is.
template <class Law>
GRANULAR_HD bool wall_on_i(const Law& law, const CylinderWall& wall, const DrumArrays& s, unsigned i,
                           WallForce<3>& o) {
  const unsigned n = s.n;
  const double x = s.x[i], z = s.x[2 * n + i], di = s.d[i];
  if (!wall.in_reach<Law>(x, z, di)) return false;
  WallContact<3> c;
  wall.geometry(x, z, di, s.v[i], s.v[n + i], s.v[2 * n + i], c.rp, c.v, c.lever, c.d_iw);
  for (int a = 0; a < 3; ++a) c.w[a] = s.w[a * n + i];
  c.di = di;
  c.ci = s.species[i];
  c.inv_mi = s.inv_m[i];
  law.wall_lane(c, o);
  return true;
}

// A cap's contact with particle i through the law's wall_lane, if the
// particle is within reach of one (EndCaps::in_reach); returns whether it is.
template <class Law>
GRANULAR_HD bool caps_on_i(const Law& law, const EndCaps& caps, const DrumArrays& s, unsigned i, WallForce<3>& o) {
  const unsigned n = s.n;
  const double y = s.x[n + i], di = s.d[i];
  if (!caps.in_reach<Law>(y, di)) return false;
  WallContact<3> c;
  caps.geometry(s.x[i], y, s.x[2 * n + i], di, s.v[i], s.v[n + i], s.v[2 * n + i], c.rp, c.v, c.lever, c.d_iw);
  for (int a = 0; a < 3; ++a) c.w[a] = s.w[a * n + i];
  c.di = di;
  c.ci = s.species[i];
  c.inv_mi = s.inv_m[i];
  law.wall_lane(c, o);
  return true;
}

// Half a step's kick from the forces (Leapfrog::kick: leapfrog_kick and
// leapfrog_spin_kick).
struct Kick {
  DrumArrays s;
  double dt;
  double g[3];

  GRANULAR_HD void kick(unsigned i) const {
    const unsigned n = s.n;
    const double h = 0.5 * dt;
    const double inv_m = s.inv_m[i], hi = h * s.inv_i[i];
    for (int a = 0; a < 3; ++a) leapfrog_kick(h, s.f[a * n + i], inv_m, g[a], s.v[a * n + i]);
    for (int a = 0; a < 3; ++a) leapfrog_spin_kick(hi, s.t[a * n + i], s.w[a * n + i]);
  }
  GRANULAR_HD void operator()(unsigned i) const { kick(i); }
};

// Stage 1: a kick, then the drift (leapfrog_drift) and the periodic wrap
// (Leapfrog's kicks_then_drift), and the squared displacement since the
// list's build (minimum image). +infinity instead where the step's move is
// longer than max_step_move or not finite (Simulation's stability test),
// which the stepper reports.
struct KickDrift {
  Kick k;
  Box box;
  double step_lim2;  // max_step_move squared

  GRANULAR_HD void operator()(unsigned i) const {
    k.kick(i);
    const DrumArrays& s = k.s;
    const unsigned n = s.n;
    double dr[3], step[3];
    for (int a = 0; a < 3; ++a) {
      double x = s.x[a * n + i];
      step[a] = leapfrog_drift(k.dt, s.v[a * n + i], x);
      x = box.wrapped(x, a);
      s.x[a * n + i] = x;
      dr[a] = x - s.x_ref[a * n + i];
    }
    box.min_image(dr);
    const double d2 = dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2];
    const double s2 = step[0] * step[0] + step[1] * step[1] + step[2] * step[2];
    const bool fine = d2 <= std::numeric_limits<double>::max() && s2 <= step_lim2;
    s.disp2[i] = fine ? d2 : std::numeric_limits<double>::infinity();
  }
};

// The cells: at least range + skin wide, so every listed pair lies in the
// same or an adjacent cell; a periodic axis too short for three cells is
// one cell (the minimum image then finds the nearest copy), as in
// neighbor/cell_list.hpp.
struct CellGrid {
  int n[3];
  bool periodic[3];
  double lo[3], width[3];

  // Particle coordinate x's cell along axis a; a particle a little outside
  // a non-periodic edge belongs to the edge cell.
  GRANULAR_HD int coord(double x, int a) const {
    double q = std::floor((x - lo[a]) / width[a]);
    q = q >= 0.0 ? q : 0.0;  // and NaN to 0
    q = q <= n[a] - 1 ? q : n[a] - 1;
    return static_cast<int>(q);
  }
  GRANULAR_HD unsigned index(int q0, int q1, int q2) const {
    return (static_cast<unsigned>(q1) * n[0] + static_cast<unsigned>(q0)) * n[2] + static_cast<unsigned>(q2);
  }
  // Cells per replica.
  GRANULAR_HD unsigned cells() const { return static_cast<unsigned>(n[0]) * n[1] * n[2]; }
};

// The positions the list is built from: the current ones for the particles
// of the replicas that rebuild (renew[r] != 0), the last build's for the
// others; then each particle's cell of its reference position, keyed by
// replica, and its index (the values the sort carries).
struct CellOf {
  DrumArrays s;
  CellGrid grid;
  const std::uint32_t* replica;
  const std::uint32_t* renew;
  std::uint32_t* cell;
  std::uint32_t* index;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    const bool moved = renew[replica[i]] != 0;
    int q[3];
    for (int a = 0; a < 3; ++a) {
      if (moved) s.x_ref[a * n + i] = s.x[a * n + i];
      q[a] = grid.coord(s.x_ref[a * n + i], a);
    }
    cell[i] = replica[i] * grid.cells() + grid.index(q[0], q[1], q[2]);
    index[i] = i;
  }
};

// Every cell's range [start, end) in the sorted order, from the sorted keys
// (cells start empty: Clear).
struct CellRanges {
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

struct Clear {
  std::uint32_t* a;
  std::uint32_t* b;
  GRANULAR_HD void operator()(unsigned k) const {
    a[k] = 0;
    b[k] = 0;
  }
};

// Particle i's full neighbour list: every j != i of i's replica within
// range(d_i, d_j) + skin at the reference positions, from the 27 cells
// around i's (fewer at a non-periodic edge or on a collapsed axis), in a
// fixed order: the cells by offset, each cell's particles by index. Column m
// of row i is nbr[m * n + i] (neighbouring threads write neighbouring
// words); count[i] is the row's length, which may exceed cap: then the
// caller enlarges the list and builds again.
template <class Law>
struct ListNeighbors {
  DrumArrays s;
  Box box;
  CellGrid grid;
  const std::uint32_t* replica;
  double skin;
  const std::uint32_t* start;
  const std::uint32_t* end;
  const std::uint32_t* sorted;
  std::uint32_t* nbr;
  std::uint32_t* count;
  unsigned cap;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    const double* xr = s.x_ref;
    const double xi[3] = {xr[i], xr[n + i], xr[2 * n + i]};
    const double di = s.d[i];
    const std::uint32_t base = replica[i] * grid.cells();
    int q[3], first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      q[a] = grid.coord(xi[a], a);
      if (grid.n[a] == 1) {
        first[a] = last[a] = 0;
      } else if (grid.periodic[a]) {
        first[a] = -1;
        last[a] = 1;
      } else {
        first[a] = q[a] > 0 ? -1 : 0;
        last[a] = q[a] < grid.n[a] - 1 ? 1 : 0;
      }
    }
    unsigned m = 0;
    for (int o0 = first[0]; o0 <= last[0]; ++o0)
      for (int o1 = first[1]; o1 <= last[1]; ++o1)
        for (int o2 = first[2]; o2 <= last[2]; ++o2) {
          const int c0 = (q[0] + o0 + grid.n[0]) % grid.n[0];
          const int c1 = (q[1] + o1 + grid.n[1]) % grid.n[1];
          const int c2 = (q[2] + o2 + grid.n[2]) % grid.n[2];
          const std::uint32_t c = base + grid.index(c0, c1, c2);
          for (std::uint32_t k = start[c], ke = end[c]; k < ke; ++k) {
            const std::uint32_t j = sorted[k];
            if (j == i) continue;
            double dr[3];
            for (int a = 0; a < 3; ++a) dr[a] = xi[a] - xr[a * n + j];
            box.min_image(dr);
            const double r2 = dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2];
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

// A drum's ends: periodic along the axis, or closed by end caps.
enum class DrumEnds { periodic, capped };

// Particle i's force and torque: the cylinder's contact, the caps' (capped
// ends), then its side of every listed pair in range, in list order.
template <class Law, DrumEnds Ends>
struct Forces {
  Law law;
  CylinderWall wall;
  EndCaps caps;
  Box box;
  DrumArrays s;
  const std::uint32_t* nbr;
  const std::uint32_t* count;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    double f[3] = {0.0, 0.0, 0.0}, t[3] = {0.0, 0.0, 0.0};
    WallForce<3> wf;
    if (wall_on_i(law, wall, s, i, wf))
      for (int a = 0; a < 3; ++a) {
        f[a] += wf.f[a];
        t[a] += wf.t[a];
      }
    if constexpr (Ends == DrumEnds::capped)
      if (caps_on_i(law, caps, s, i, wf))
        for (int a = 0; a < 3; ++a) {
          f[a] += wf.f[a];
          t[a] += wf.t[a];
        }
    for (std::uint32_t m = 0, me = count[i]; m < me; ++m) {
      PairForce<3> pf;
      if (!pair_on_i(law, box, s, i, nbr[m * n + i], pf)) continue;
      for (int a = 0; a < 3; ++a) {
        f[a] += pf.f[a];
        t[a] += pf.ti[a];
      }
    }
    for (int a = 0; a < 3; ++a) {
      s.f[a * n + i] = f[a];
      s.t[a * n + i] = t[a];
    }
  }
};

// Particle i's worst overlap over its listed pairs in range, as a fraction
// of the contact distance, (range - r) / range with r the centres' distance
// (engine/health.hpp's measure; -infinity without one), or +infinity if its
// position or velocity is not finite.
template <class Law>
struct WorstOverlap {
  DrumArrays s;
  Box box;
  const std::uint32_t* nbr;
  const std::uint32_t* count;
  double* out;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    // v - v is 0 for a finite v, NaN for an infinite or NaN one.
    double zero = 0.0;
    for (int a = 0; a < 3; ++a)
      zero += (s.x[a * n + i] - s.x[a * n + i]) + (s.v[a * n + i] - s.v[a * n + i]) + (s.w[a * n + i] - s.w[a * n + i]);
    if (!(zero == 0.0)) {
      out[i] = std::numeric_limits<double>::infinity();
      return;
    }
    double worst = -std::numeric_limits<double>::infinity();
    for (std::uint32_t m = 0, me = count[i]; m < me; ++m) {
      const unsigned j = nbr[m * n + i];
      double dr[3];
      for (int a = 0; a < 3; ++a) dr[a] = s.x[a * n + i] - s.x[a * n + j];
      box.min_image(dr);
      const double r = std::sqrt(dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2]);
      const double rc = Law::range(s.d[i], s.d[j]);
      const double ov = (rc - r) / rc;
      if (r < rc && ov > worst) worst = ov;
    }
    out[i] = worst;
  }
};

// The stepper: the state of one or several replicas in DeviceArrays (the
// replicas' particles one after another) and the step above, for one kind
// of ends.
template <class Law, DrumEnds Ends>
class DrumKernels final : public DrumStepper {
 public:
  DrumKernels(const Law& law, const std::vector<DrumModel>& ms)
      : law_(law), wall_(ms.front().wall), caps_(ms.front().caps), time_(ms.front().time), steps_(ms.front().step_count) {
    const DrumModel& m = ms.front();
    k_ = static_cast<unsigned>(ms.size());
    std::size_t total = 0;
    offsets_.push_back(0);
    for (const DrumModel& r : ms) {
      if (r.time != m.time || r.step_count != m.step_count || r.p.size() == 0)
        throw std::invalid_argument("GPU drum: replicas must start at the same step, each with particles");
      if (r.capped != (Ends == DrumEnds::capped)) throw std::invalid_argument("GPU drum: replicas must all have the same ends");
      total += r.p.size();
      if (total >= std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument("GPU drum: too many particles for 32-bit indices");
      offsets_.push_back(static_cast<std::uint32_t>(total));
    }
    n_ = static_cast<unsigned>(total);
    dt_ = m.dt;
    skin_ = m.skin;
    step_lim2_ = std::numeric_limits<double>::infinity();
    for (const DrumModel& r : ms) step_lim2_ = std::min(step_lim2_, r.max_step_move * r.max_step_move);
    for (int a = 0; a < 3; ++a) {
      box_.lo[a] = m.lo[a];
      box_.len[a] = m.hi[a] - m.lo[a];
      box_.inv_len[a] = m.periodic[a] ? 1.0 / box_.len[a] : 0.0;  // Domain::finalize
      g_[a] = m.gravity[a];
    }
    upload(ms);
    // Cells sized for the widest particle (the drum has one size class).
    double d_max = 0.0;
    for (const DrumModel& r : ms)
      for (double d : r.p.d) d_max = std::max(d_max, d);
    const auto c = cell_counts(m, Law::range(d_max, d_max) + skin_);
    for (int a = 0; a < 3; ++a) {
      grid_.n[a] = c[a];
      grid_.periodic[a] = m.periodic[a];
      grid_.lo[a] = m.lo[a];
      grid_.width[a] = box_.len[a] / c[a];
    }
    const std::uint64_t keys = std::uint64_t{grid_.cells()} * k_;
    if (keys >= std::numeric_limits<std::uint32_t>::max() / 2)
      throw std::invalid_argument("GPU drum: too many cells for 32-bit keys");
    end_bit_ = 1;
    while ((std::uint64_t{1} << end_bit_) < keys) ++end_bit_;
    cell_start_.resize(keys);
    cell_end_.resize(keys);
    cell_.resize(n_);
    index_.resize(n_);
    sorted_cell_.resize(n_);
    sorted_.resize(n_);
    count_.resize(n_);
    disp2_.resize(n_);
    // A resumed run builds its list from the saved reference positions and
    // keeps the saved forces; a new one builds from the positions and
    // computes the forces.
    const bool resumed = !m.x_ref.empty();
    renew_host_.assign(k_, resumed ? 0u : 1u);
    if (resumed) {
      std::vector<double> h(3 * static_cast<std::size_t>(n_));
      for (unsigned r = 0; r < k_; ++r) {
        if (ms[r].x_ref.size() != ms[r].p.size())
          throw std::invalid_argument("GPU drum: every replica resumes with its reference positions");
        for (std::size_t i = 0; i < ms[r].p.size(); ++i)
          for (int a = 0; a < 3; ++a) h[a * n_ + offsets_[r] + i] = ms[r].x_ref[i][a];
      }
      x_ref_.upload(h);
    } else {
      x_ref_.resize(3 * static_cast<std::size_t>(n_));
    }
    build();
    if (!resumed) forces();
    synchronize();
  }

  void advance(long steps) override {
    const double lim2 = 0.25 * skin_ * skin_;  // (skin/2)^2
    for (long k = 0; k < steps; ++k) {
      for_each(n_, KickDrift{kick(), box_, step_lim2_});
      segment_max(disp2_.data(), offsets_, offsets_dev_.data(), k_, moved2_, max_d_, scratch_);
      bool any = false;
      for (unsigned r = 0; r < k_; ++r) {
        if (!(moved2_[r] <= std::numeric_limits<double>::max())) throw StepUnstable(static_cast<int>(r));
        renew_host_[r] = moved2_[r] > lim2;
        any = any || renew_host_[r];
      }
      if (any) build();
      forces();
      for_each(n_, kick());
      time_ += dt_;
      ++steps_;
    }
    synchronize();
  }

  void download(ParticleStore<3>& p, int r) const override {
    const unsigned off = offsets_.at(r), len = offsets_.at(r + 1) - off;
    if (p.size() != len) throw std::invalid_argument("GPU drum: download into a store of another size");
    const auto x = x_.download(), v = v_.download(), w = w_.download(), f = f_.download(), t = t_.download();
    for (unsigned i = 0; i < len; ++i)
      for (int a = 0; a < 3; ++a) {
        const std::size_t at = static_cast<std::size_t>(a) * n_ + off + i;
        p.x[i][a] = x[at];
        p.v[i][a] = v[at];
        p.w[i][a] = w[at];
        p.f[i][a] = f[at];
        p.tq[i][a] = t[at];
      }
  }

  Column<Eigen::Vector3d> reference_positions(int r) const override {
    const unsigned off = offsets_.at(r), len = offsets_.at(r + 1) - off;
    const auto h = x_ref_.download();
    Column<Eigen::Vector3d> out(len);
    for (unsigned i = 0; i < len; ++i)
      for (int a = 0; a < 3; ++a) out[i][a] = h[static_cast<std::size_t>(a) * n_ + off + i];
    return out;
  }

  std::vector<double> worst_overlap() override {
    health_.resize(n_);
    for_each(n_, WorstOverlap<Law>{arrays(), box_, nbr_.data(), count_.data(), health_.data()});
    std::vector<double> out;
    segment_max(health_.data(), offsets_, offsets_dev_.data(), k_, out, max_d_, scratch_);
    return out;
  }

  int replicas() const override { return static_cast<int>(k_); }
  double time() const override { return time_; }
  long step_count() const override { return steps_; }
  long builds() const override { return builds_; }
  const char* backend() const override { return kBackend; }

 private:
  DrumArrays arrays() {
    return DrumArrays{x_.data(), v_.data(), w_.data(), f_.data(),   t_.data(),     d_.data(),
                      inv_m_.data(), inv_i_.data(), species_.data(), x_ref_.data(), disp2_.data(), n_};
  }
  Kick kick() { return Kick{arrays(), dt_, {g_[0], g_[1], g_[2]}}; }

  // A vector column of every replica's store into one component-major array.
  template <class Get>
  void upload_vectors(const std::vector<DrumModel>& ms, Get get, DeviceArray<double>& out) {
    std::vector<double> h(3 * static_cast<std::size_t>(n_));
    for (unsigned r = 0; r < k_; ++r) {
      const auto& col = get(ms[r].p);
      for (std::size_t i = 0; i < col.size(); ++i)
        for (int a = 0; a < 3; ++a) h[a * n_ + offsets_[r] + i] = col[i][a];
    }
    out.upload(h);
  }
  template <class T, class Get>
  void upload_scalars(const std::vector<DrumModel>& ms, Get get, DeviceArray<T>& out) {
    std::vector<T> h;
    h.reserve(n_);
    for (const DrumModel& r : ms)
      for (const auto& e : get(r.p)) h.push_back(static_cast<T>(e));
    out.upload(h);
  }
  void upload(const std::vector<DrumModel>& ms) {
    upload_vectors(ms, [](const ParticleStore<3>& p) -> const auto& { return p.x; }, x_);
    upload_vectors(ms, [](const ParticleStore<3>& p) -> const auto& { return p.v; }, v_);
    upload_vectors(ms, [](const ParticleStore<3>& p) -> const auto& { return p.w; }, w_);
    upload_vectors(ms, [](const ParticleStore<3>& p) -> const auto& { return p.f; }, f_);
    upload_vectors(ms, [](const ParticleStore<3>& p) -> const auto& { return p.tq; }, t_);
    upload_scalars<double>(ms, [](const ParticleStore<3>& p) -> const auto& { return p.d; }, d_);
    upload_scalars<double>(ms, [](const ParticleStore<3>& p) -> const auto& { return p.inv_m; }, inv_m_);
    upload_scalars<double>(ms, [](const ParticleStore<3>& p) -> const auto& { return p.inv_i; }, inv_i_);
    upload_scalars<std::int32_t>(ms, [](const ParticleStore<3>& p) -> const auto& { return p.species; }, species_);
    std::vector<std::uint32_t> rep(n_);
    for (unsigned r = 0; r < k_; ++r)
      for (std::uint32_t i = offsets_[r]; i < offsets_[r + 1]; ++i) rep[i] = r;
    replica_.upload(rep);
    offsets_dev_.upload(offsets_);
  }

  // The cell sort and the full list from the reference positions, renewed
  // for the replicas marked in renew_host_; the list grows until every row
  // fits.
  void build() {
    const DrumArrays s = arrays();
    renew_.upload(renew_host_);
    for_each(n_, CellOf{s, grid_, replica_.data(), renew_.data(), cell_.data(), index_.data()});
    sort_pairs(cell_.data(), sorted_cell_.data(), index_.data(), sorted_.data(), n_, end_bit_, scratch_);
    for_each(static_cast<unsigned>(cell_start_.size()), Clear{cell_start_.data(), cell_end_.data()});
    for_each(n_, CellRanges{sorted_cell_.data(), cell_start_.data(), cell_end_.data(), n_});
    while (true) {
      nbr_.resize(static_cast<std::size_t>(cap_) * n_);
      for_each(n_, ListNeighbors<Law>{s, box_, grid_, replica_.data(), skin_, cell_start_.data(), cell_end_.data(),
                                      sorted_.data(), nbr_.data(), count_.data(), cap_});
      const std::uint32_t longest = max_of(count_.data(), n_, std::uint32_t{0}, max_count_, scratch_);
      if (longest <= cap_) break;
      cap_ = longest + longest / 4 + 8;
    }
    ++builds_;
  }

  void forces() {
    for_each(n_, Forces<Law, Ends>{law_, wall_, caps_, box_, arrays(), nbr_.data(), count_.data()});
  }

  Law law_;
  CylinderWall wall_;
  EndCaps caps_;
  unsigned n_ = 0, k_ = 1;
  std::vector<std::uint32_t> offsets_;     // replica r: particles [offsets_[r], offsets_[r + 1])
  std::vector<std::uint32_t> renew_host_;  // per replica: its reference positions are renewed at the next build
  std::vector<double> moved2_;             // per replica: the step's largest squared displacement
  double time_;
  long steps_;
  long builds_ = 0;
  double dt_ = 0.0, skin_ = 0.0, step_lim2_ = 0.0;
  double g_[3] = {0.0, 0.0, 0.0};
  Box box_{};
  CellGrid grid_{};
  int end_bit_ = 1;
  unsigned cap_ = 32;  // list columns per particle
  DeviceArray<double> x_, v_, w_, f_, t_, d_, inv_m_, inv_i_, x_ref_, disp2_, max_d_, health_;
  DeviceArray<std::int32_t> species_;
  DeviceArray<std::uint32_t> cell_, index_, sorted_cell_, sorted_, cell_start_, cell_end_, nbr_, count_, max_count_;
  DeviceArray<std::uint32_t> replica_, renew_, offsets_dev_;
  Scratch scratch_;
};

// A stepper for the replicas' law and ends (the first's: the replicas are
// one scene), in this build.
inline std::unique_ptr<DrumStepper> make_drum_stepper(const std::vector<DrumModel>& ms) {
  if (ms.empty()) throw std::invalid_argument("GPU drum: no replica to step");
  return std::visit(
      [&](const auto& law) -> std::unique_ptr<DrumStepper> {
        using Law = std::decay_t<decltype(law)>;
        if (ms.front().capped) return std::make_unique<DrumKernels<Law, DrumEnds::capped>>(law, ms);
        return std::make_unique<DrumKernels<Law, DrumEnds::periodic>>(law, ms);
      },
      ms.front().law);
}

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
