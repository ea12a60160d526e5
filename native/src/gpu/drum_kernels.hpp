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
//               the squared displacement since the last list build
//   rebuild     if the largest displacement exceeds skin/2: particles sorted
//               by cell (sort_pairs), each cell's range in the sorted order,
//               then every particle lists every neighbour within
//               range + skin (a full list, in the order of the cell stencil)
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
  double* disp2;  // squared displacement since then
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
// (Leapfrog's kicks_then_drift), and the squared displacement since the list's build
// (minimum image; a non-finite one as +infinity, which the stepper reports).
struct KickDrift {
  Kick k;
  Box box;

  GRANULAR_HD void operator()(unsigned i) const {
    k.kick(i);
    const DrumArrays& s = k.s;
    const unsigned n = s.n;
    double dr[3];
    for (int a = 0; a < 3; ++a) {
      double x = s.x[a * n + i];
      leapfrog_drift(k.dt, s.v[a * n + i], x);
      x = box.wrapped(x, a);
      s.x[a * n + i] = x;
      dr[a] = x - s.x_ref[a * n + i];
    }
    box.min_image(dr);
    const double d2 = dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2];
    s.disp2[i] = d2 <= std::numeric_limits<double>::max() ? d2 : std::numeric_limits<double>::infinity();
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
  unsigned cells() const { return static_cast<unsigned>(n[0]) * n[1] * n[2]; }
};

// Each particle's cell and its index (the values the sort carries), and the
// positions the list is built from.
struct CellOf {
  DrumArrays s;
  CellGrid grid;
  std::uint32_t* cell;
  std::uint32_t* index;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    int q[3];
    for (int a = 0; a < 3; ++a) {
      q[a] = grid.coord(s.x[a * n + i], a);
      s.x_ref[a * n + i] = s.x[a * n + i];
    }
    cell[i] = grid.index(q[0], q[1], q[2]);
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

// Particle i's full neighbour list: every j != i within range(d_i, d_j) +
// skin, from the 27 cells around i's (fewer at a non-periodic edge or on a
// collapsed axis), in a fixed order: the cells by offset, each cell's
// particles by index. Column m of row i is nbr[m * n + i] (neighbouring
// threads write neighbouring words); count[i] is the row's length, which
// may exceed cap: then the caller enlarges the list and builds again.
template <class Law>
struct ListNeighbors {
  DrumArrays s;
  Box box;
  CellGrid grid;
  double skin;
  const std::uint32_t* start;
  const std::uint32_t* end;
  const std::uint32_t* sorted;
  std::uint32_t* nbr;
  std::uint32_t* count;
  unsigned cap;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    const double xi[3] = {s.x[i], s.x[n + i], s.x[2 * n + i]};
    const double di = s.d[i];
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
          const std::uint32_t c = grid.index(c0, c1, c2);
          for (std::uint32_t k = start[c], ke = end[c]; k < ke; ++k) {
            const std::uint32_t j = sorted[k];
            if (j == i) continue;
            double dr[3];
            for (int a = 0; a < 3; ++a) dr[a] = xi[a] - s.x[a * n + j];
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

// Particle i's force and torque: the cylinder's contact, the caps' (Capped),
// then its side of every listed pair in range, in list order.
template <class Law, bool Capped>
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
    if constexpr (Capped)
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

// The stepper: the state in DeviceArrays and the step above; Capped: with
// end caps.
template <class Law, bool Capped>
class DrumKernels final : public DrumStepper {
 public:
  DrumKernels(const Law& law, const DrumModel& m)
      : law_(law),
        wall_(m.wall),
        caps_(m.caps),
        n_(static_cast<unsigned>(m.p.size())),
        time_(m.time),
        steps_(m.step_count) {
    if (m.p.size() >= std::numeric_limits<std::uint32_t>::max())
      throw std::invalid_argument("GPU drum: too many particles for 32-bit indices");
    dt_ = m.dt;
    skin_ = m.skin;
    for (int a = 0; a < 3; ++a) {
      box_.lo[a] = m.lo[a];
      box_.len[a] = m.hi[a] - m.lo[a];
      box_.inv_len[a] = m.periodic[a] ? 1.0 / box_.len[a] : 0.0;  // Domain::finalize
      g_[a] = m.gravity[a];
    }
    upload(m.p);
    // Cells sized for the widest particle (the drum has one size class).
    double d_max = 0.0;
    for (double d : m.p.d) d_max = std::max(d_max, d);
    const double min_cell = Law::range(d_max, d_max) + skin_;
    for (int a = 0; a < 3; ++a) {
      int c = std::max(1, static_cast<int>(box_.len[a] / min_cell));
      if (m.periodic[a] && c < 3) c = 1;
      grid_.n[a] = c;
      grid_.periodic[a] = m.periodic[a];
      grid_.lo[a] = m.lo[a];
      grid_.width[a] = box_.len[a] / c;
    }
    if (grid_.cells() >= std::numeric_limits<std::uint32_t>::max() / 2)
      throw std::invalid_argument("GPU drum: too many cells for 32-bit keys");
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
    x_ref_.resize(3 * static_cast<std::size_t>(n_));
    build();
    forces();
    synchronize();
  }

  void advance(long steps) override {
    const double lim2 = 0.25 * skin_ * skin_;  // (skin/2)^2
    for (long k = 0; k < steps; ++k) {
      for_each(n_, KickDrift{kick(), box_});
      const double moved2 = max_of(disp2_.data(), n_, 0.0, max_d_, scratch_);
      if (!(moved2 <= std::numeric_limits<double>::max()))
        throw std::runtime_error("GPU drum: a particle's position is not finite at step " +
                                 std::to_string(steps_ + 1) + " (t = " + std::to_string(time_ + dt_) +
                                 "); reduce integrator.dt or check the contact parameters");
      if (moved2 > lim2) build();
      forces();
      for_each(n_, kick());
      time_ += dt_;
      ++steps_;
    }
    synchronize();
  }

  void download(ParticleStore<3>& p) const override {
    if (p.size() != n_) throw std::invalid_argument("GPU drum: download into a store of another size");
    const auto x = x_.download(), v = v_.download(), w = w_.download(), f = f_.download(), t = t_.download();
    for (unsigned i = 0; i < n_; ++i)
      for (int a = 0; a < 3; ++a) {
        p.x[i][a] = x[a * n_ + i];
        p.v[i][a] = v[a * n_ + i];
        p.w[i][a] = w[a * n_ + i];
        p.f[i][a] = f[a * n_ + i];
        p.tq[i][a] = t[a * n_ + i];
      }
  }

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

  // A vector column of the store into a component-major array.
  static void upload_vectors(const Column<Eigen::Vector3d>& col, DeviceArray<double>& out) {
    const std::size_t n = col.size();
    std::vector<double> h(3 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) h[a * n + i] = col[i][a];
    out.upload(h);
  }
  void upload(const ParticleStore<3>& p) {
    upload_vectors(p.x, x_);
    upload_vectors(p.v, v_);
    upload_vectors(p.w, w_);
    upload_vectors(p.f, f_);
    upload_vectors(p.tq, t_);
    d_.upload(p.d.data(), p.d.size());
    inv_m_.upload(p.inv_m.data(), p.inv_m.size());
    inv_i_.upload(p.inv_i.data(), p.inv_i.size());
    species_.upload(p.species.data(), p.species.size());
  }

  // The cell sort and the full list, from the current positions; the list
  // grows until every row fits.
  void build() {
    const DrumArrays s = arrays();
    for_each(n_, CellOf{s, grid_, cell_.data(), index_.data()});
    sort_pairs(cell_.data(), sorted_cell_.data(), index_.data(), sorted_.data(), n_, end_bit_, scratch_);
    for_each(grid_.cells(), Clear{cell_start_.data(), cell_end_.data()});
    for_each(n_, CellRanges{sorted_cell_.data(), cell_start_.data(), cell_end_.data(), n_});
    while (true) {
      nbr_.resize(static_cast<std::size_t>(cap_) * n_);
      for_each(n_, ListNeighbors<Law>{s, box_, grid_, skin_, cell_start_.data(), cell_end_.data(), sorted_.data(),
                                      nbr_.data(), count_.data(), cap_});
      const std::uint32_t longest = max_of(count_.data(), n_, std::uint32_t{0}, max_count_, scratch_);
      if (longest <= cap_) break;
      cap_ = longest + longest / 4 + 8;
    }
    ++builds_;
  }

  void forces() {
    for_each(n_, Forces<Law, Capped>{law_, wall_, caps_, box_, arrays(), nbr_.data(), count_.data()});
  }

  Law law_;
  CylinderWall wall_;
  EndCaps caps_;
  unsigned n_;
  double time_;
  long steps_;
  long builds_ = 0;
  double dt_ = 0.0, skin_ = 0.0;
  double g_[3] = {0.0, 0.0, 0.0};
  Box box_{};
  CellGrid grid_{};
  int end_bit_ = 1;
  unsigned cap_ = 32;  // list columns per particle
  DeviceArray<double> x_, v_, w_, f_, t_, d_, inv_m_, inv_i_, x_ref_, disp2_, max_d_;
  DeviceArray<std::int32_t> species_;
  DeviceArray<std::uint32_t> cell_, index_, sorted_cell_, sorted_, cell_start_, cell_end_, nbr_, count_, max_count_;
  Scratch scratch_;
};

// A stepper for the model's law and ends, in this build.
inline std::unique_ptr<DrumStepper> make_drum_stepper(const DrumModel& m) {
  return std::visit(
      [&](const auto& law) -> std::unique_ptr<DrumStepper> {
        using Law = std::decay_t<decltype(law)>;
        if (m.capped) return std::make_unique<DrumKernels<Law, true>>(law, m);
        return std::make_unique<DrumKernels<Law, false>>(law, m);
      },
      m.law);
}

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
