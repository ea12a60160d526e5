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
//               positions only (gpu/neighbor_kernels.hpp, the box's too)
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
#include "gpu/kernel_stepper.hpp"
#include "gpu/neighbor_kernels.hpp"
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

// The particles (ParticleArrays) and the list's reference positions and
// displacements.
struct DrumArrays : ParticleArrays {
  double* x_ref;  // positions at the last list build
  double* disp2;  // squared displacement since then (+infinity: an unstable step)
  unsigned n;
};

// Particle i's side of the pair (i, j) (pair_side), the minimum image along
// the periodic axis.
template <class Law>
GRANULAR_HD bool pair_on_i(const Law& law, const Box& box, const DrumArrays& s, unsigned i, unsigned j,
                           PairForce<3>& o) {
  return pair_side(law, box, s, s.n, i, j, o);
}

// A wall's contact with particle i through the law's wall_lane, the
// contact's geometry (rp, v, lever, d_iw) given, the particle's spin,
// diameter, species and inverse mass added.
template <class Law>
GRANULAR_HD void wall_lane_on_i(const Law& law, const DrumArrays& s, unsigned i, WallContact<3>& c,
                                WallForce<3>& o) {
  const unsigned n = s.n;
  for (int a = 0; a < 3; ++a) c.w[a] = s.w[a * n + i];
  c.di = s.d[i];
  c.ci = s.species[i];
  c.inv_mi = s.inv_m[i];
  law.wall_lane(c, o);
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
  wall_lane_on_i(law, s, i, c, o);
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
  wall_lane_on_i(law, s, i, c, o);
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
  ListRows list;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    double f[3] = {0.0, 0.0, 0.0}, t[3] = {0.0, 0.0, 0.0};
    WallForce<3> wf;
    const auto add = [&] {
      for (int a = 0; a < 3; ++a) {
        f[a] += wf.f[a];
        t[a] += wf.t[a];
      }
    };
    if (wall_on_i(law, wall, s, i, wf)) add();
    if constexpr (Ends == DrumEnds::capped)
      if (caps_on_i(law, caps, s, i, wf)) add();
    add_listed_pairs(law, box, s, n, list, i, f, t);
    store_force(s, n, i, f, t);
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
  ListRows list;
  double* out;

  GRANULAR_HD void operator()(unsigned i) const {
    out[i] = finite_motion<3, 3>(s.x, s.v, s.w, s.n, i)
                 ? worst_listed_overlap<Law, 3>(s.x, s.d, s.n, box, list, i)
                 : std::numeric_limits<double>::infinity();
  }
};

// The stepper: the state of one or several replicas (gpu/kernel_stepper.hpp)
// and the step above, for one kind of ends.
template <class Law, DrumEnds Ends>
class DrumKernels final : public KernelStepper<3> {
 public:
  DrumKernels(const Law& law, const std::vector<DrumModel>& ms)
      : KernelStepper<3>("GPU drum", pointers(ms)), law_(law), wall_(ms.front().wall), caps_(ms.front().caps) {
    const DrumModel& m = ms.front();
    for (const DrumModel& r : ms)
      if (r.capped != (Ends == DrumEnds::capped))
        throw std::invalid_argument("GPU drum: replicas must all have the same ends");
    for (int a = 0; a < 3; ++a) {
      box_.lo[a] = m.lo[a];
      box_.len[a] = m.hi[a] - m.lo[a];
      box_.inv_len[a] = m.periodic[a] ? 1.0 / box_.len[a] : 0.0;  // Domain::finalize
    }
    // Cells sized for the widest particle (the drum has one size class).
    reserve_list<Law>(m.lo, m.hi, m.periodic, 32);
    // A resumed run builds its list from the saved reference positions and
    // keeps the saved forces; a new one builds from the positions and
    // computes the forces.
    build<Law>(box_, AllPairs{});
    if (!resumed_) forces();
    synchronize();
  }

  // Each step's second kick and the next step's first stage run as one
  // launch (then()); the last step's second kick alone.
  void advance(long steps) override {
    if (steps <= 0) return;
    for_each(n_, first_stage());
    for (long k = 0; k < steps; ++k) {
      if (must_rebuild()) build<Law>(box_, AllPairs{});
      forces();
      if (k + 1 < steps)
        for_each(n_, then(kick(), first_stage()));
      else
        for_each(n_, kick());
      time_ += dt_;
      ++steps_;
    }
    synchronize();
  }

  std::vector<double> worst_overlap() override {
    for_each(n_, WorstOverlap<Law>{arrays(), box_, rows(), health()});
    return worst_of_health();
  }

 private:
  static std::vector<const DrumModel*> pointers(const std::vector<DrumModel>& ms) {
    std::vector<const DrumModel*> out;
    for (const DrumModel& m : ms) out.push_back(&m);
    return out;
  }

  DrumArrays arrays() {
    return DrumArrays{x_.data(),     v_.data(),     w_.data(),       f_.data(),     t_.data(),     d_.data(),
                      inv_m_.data(), inv_i_.data(), species_.data(), x_ref_.data(), disp2_.data(), n_};
  }
  Kick kick() { return Kick{arrays(), dt_, {g_[0], g_[1], g_[2]}}; }
  KickDrift first_stage() { return KickDrift{kick(), box_, step_lim2_}; }

  void forces() { for_each(n_, Forces<Law, Ends>{law_, wall_, caps_, box_, arrays(), rows()}); }

  Law law_;
  CylinderWall wall_;
  EndCaps caps_;
  Box box_{};
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
