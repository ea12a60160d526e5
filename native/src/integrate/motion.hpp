// Prescribed motion of wall particles (walls made of particles, Poeschel and
// Herrmann 1995): ordinary particles of species kWallSpecies whose position and
// velocity are set from a closed-form motion instead of being integrated.
// NoMotion is the default for scenes without wall particles and compiles away.
#pragma once
#include <cmath>
#include <algorithm>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/particles.hpp"

namespace granular {

inline constexpr int kWallSpecies = 2;

struct NoMotion {};

// The box moves as y_box = A s(t) sin(phi(t)), phi = 2 pi int f dt' from the
// start of shaking, with the frequency ramped linearly from f0 to f1 over
// [ramp_start, ramp_start + ramp_time] (constant f0 when ramp_time = 0).
// Shaking starts at t = start; s rises linearly from 0 to 1 over the first
// startup_cycles cycles (0: full amplitude at once, which jolts the bed with the
// box's full speed A 2 pi f at the first step).
template <int Dim>
struct ShakerMotion {
  using V = Vec<Dim>;
  double amplitude = 2.0;  // A, cm
  double f0 = 3.0, f1 = 3.0;
  double start = 0.0;       // shaking begins (after settling)
  double ramp_start = 0.0;  // relative to start
  double ramp_time = 0.0;
  double startup_cycles = 0.0;
  std::vector<V> anchor;  // by particle id: rest position of each wall particle

  double frequency(double t) const {
    const double s = t - start - ramp_start;
    if (ramp_time <= 0.0 || s <= 0.0) return s > 0.0 && ramp_time <= 0.0 ? f1 : f0;
    return s >= ramp_time ? f1 : f0 + (f1 - f0) * s / ramp_time;
  }
  // phase(t) = 2 pi int_start^t f(t') dt'
  double phase(double t) const {
    const double u = t - start;
    if (u <= 0.0) return 0.0;
    if (ramp_time <= 0.0) return 2.0 * M_PI * f0 * u;
    const double a = std::min(u, ramp_start);
    const double s = std::clamp(u - ramp_start, 0.0, ramp_time);
    const double b = std::max(0.0, u - ramp_start - ramp_time);
    return 2.0 * M_PI * (f0 * a + f0 * s + 0.5 * (f1 - f0) * s * s / ramp_time + f1 * b);
  }
  // Envelope s(t) and its time derivative.
  double envelope(double t) const {
    if (startup_cycles <= 0.0) return t > start ? 1.0 : 0.0;
    return std::clamp(phase(t) / (2.0 * M_PI * startup_cycles), 0.0, 1.0);
  }
  double y(double t) const { return amplitude * envelope(t) * std::sin(phase(t)); }
  double vy(double t) const {
    if (t <= start) return 0.0;
    const double omega = 2.0 * M_PI * frequency(t), ph = phase(t);
    double v = amplitude * envelope(t) * std::cos(ph) * omega;
    if (startup_cycles > 0.0 && ph < 2.0 * M_PI * startup_cycles)
      v += amplitude * std::sin(ph) * omega / (2.0 * M_PI * startup_cycles);
    return v;
  }

  // The box's displacement and velocity at one time, as vectors: evaluated
  // once per step, not once per wall particle (three transcendental calls
  // each). Whole vectors, so that placing a particle is one add and two
  // stores: setting one component of a copy in memory and storing the copy
  // whole stalls the store on the piecewise writes (measured: a wall cost 4
  // times a grain in the first stage).
  struct Pose {
    V dx = V::Zero(), v = V::Zero();
  };
  Pose pose(double t) const {
    Pose b;
    b.dx[1] = y(t);
    b.v[1] = vy(t);
    return b;
  }

  void place(ParticleStore<Dim>& p, std::size_t i, const Pose& b) const {
    p.x[i] = anchor[static_cast<std::size_t>(p.id[i])] + b.dx;
    p.v[i] = b.v;
    p.w[i].setZero();
  }
};

struct NoPose {};
inline NoPose pose_at(const NoMotion&, double) { return {}; }
template <int Dim>
typename ShakerMotion<Dim>::Pose pose_at(const ShakerMotion<Dim>& m, double t) {
  return m.pose(t);
}

template <class Motion>
inline constexpr bool kHasMotion = !std::is_same_v<Motion, NoMotion>;

// For the integrators' first stage: if particle i is a wall particle, put it
// where the motion's pose (pose_at(motion, t_next), once per step) says,
// record its displacement and return true.
template <class Motion, class Pose, int Dim, class Stats, class DomainT>
inline bool place_if_wall(const Motion& motion, const Pose& pose, ParticleStore<Dim>& p, std::size_t i,
                          const DomainT& domain, const Vec<Dim>& x_ref, Stats& st) {
  if constexpr (kHasMotion<Motion>) {
    if (p.species[i] == kWallSpecies) {
      const Vec<Dim> old = p.x[i];
      motion.place(p, i, pose);
      st.add(domain, i, (p.x[i] - old).squaredNorm(), p.x[i], x_ref);
      return true;
    }
  }
  return false;
}

}  // namespace granular
