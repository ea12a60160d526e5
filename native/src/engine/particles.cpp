#include "engine/particles.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "engine/contact_setup.hpp"
#include "engine/health.hpp"
#include "engine/run_control.hpp"
#include "scene/step_rule.hpp"

namespace granular {

namespace {

// The neighbour list's domain (core/domain.hpp, open on every axis): the particles'
// bounding box grown by two of the largest diameters and the skin. A particle
// that leaves it is counted in the nearest edge cell (neighbor/cell_list.hpp),
// which keeps every pair in range in the same or adjacent cells, so the domain
// only sizes the cells. Where the particles are spread so thinly that the domain
// would hold more than kMaxCells cells, it shrinks about its centre.
template <class Sim>
void set_domain(Sim& sim, const ParticlesScene& s) {
  constexpr double kMaxCells = 4e6;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = Eigen::Vector3d::Constant(-INFINITY);
  double d_max = 0.0;
  for (std::size_t i = 0; i < sim.p.size(); ++i) {
    lo = lo.cwiseMin(sim.p.x[i]);
    hi = hi.cwiseMax(sim.p.x[i]);
    d_max = std::max(d_max, sim.p.d[i]);
  }
  const double margin = 2.0 * d_max + s.skin;
  lo.array() -= margin;
  hi.array() += margin;
  const double cell = std::decay_t<decltype(sim.law)>::range(d_max, d_max) + s.skin;
  const Eigen::Vector3d len = hi - lo;
  const double cells = std::max(1.0, len.x() / cell) * std::max(1.0, len.y() / cell) * std::max(1.0, len.z() / cell);
  if (cells > kMaxCells) {
    const double shrink = std::cbrt(kMaxCells / cells);
    const Eigen::Vector3d mid = 0.5 * (lo + hi), half = (0.5 * shrink * len).cwiseMax(Eigen::Vector3d::Constant(cell));
    lo = mid - half;
    hi = mid + half;
  }
  sim.domain.lo = lo;
  sim.domain.hi = hi;
  sim.domain.periodic = {false, false, false};
  sim.domain.finalize();
}

template <class Sim>
void configure(Sim& sim, const ParticlesScene& s) {
  sim.p = particles_store(s);
  const WallGeometry wg = set_contact_law(sim, mapping_inputs(s), s.kappa);
  PlaneWalls& walls = std::get<PlaneWalls>(sim.walls);
  for (const auto& w : s.walls) walls.planes.push_back({w.point + wg.inset * w.normal, w.normal});
  walls.d_wall = wg.d_wall;
  const bool paper = s.wall_lever == "paper";
  walls.lever = WallLever{paper ? 1.0 : 0.0, paper ? 0.0 : 1.0};
  set_domain(sim, s);
  sim.integrator.dt = s.dt;
  sim.integrator.gravity = Eigen::Vector3d(0.0, 0.0, -s.gravity);  // g along -z
  sim.skin = s.skin;
  sim.init();
}

// What can drive a particle (engine/health.hpp): its initial speed, the
// energy of the initial overlaps, and gravity over the whole run (an open
// domain: a particle may fall for all of it); and the shortest contact.
template <class Sim>
HealthLimits particles_health(const ParticlesScene& s) {
  HealthLimits h;
  const double fall = s.gravity * s.duration;
  h.max_speed = 8.0 * std::max(s.max_speed + s.release_speed + fall, 1e-3);
  std::ostringstream os;
  os << "fastest initial particle " << s.max_speed << ", the initial overlaps' energy " << s.release_speed
     << ", free fall over the run " << fall << ", x8";
  h.speed_sources = os.str();
  h.dt = s.dt;
  const StepRule r = particles_step_rule(s);
  constexpr bool rapaport = std::is_same_v<decltype(Sim::law), RapaportLaw<3>>;
  if (rapaport) {
    h.contact_period = r.contact_time;
    h.impact_speed = r.impact_speed;
    h.impact_contact = r.contact_time;
    h.impact_steps_needed = r.steps_per_contact;
  } else {
    const LinearMapping m = map_rapaport_to_linear(mapping_inputs(s));  // checked when the scene was read
    double t = INFINITY;
    for (int k = 0; k < 3; ++k) t = std::min(t, m.pair_linear[k].contact_time);
    if (!s.walls.empty())
      for (int a = 0; a < 2; ++a) t = std::min(t, m.wall_linear[a].contact_time);
    h.contact_period = t;
  }
  return h;
}

// A particle whose centre is behind a wall went through it.
template <class Sim>
void check_sides(const Sim& sim) {
  const PlaneWalls& walls = std::get<PlaneWalls>(sim.walls);
  const auto b = walls.behind(sim.p);
  if (b.particle == sim.p.size()) return;
  const auto& x = sim.p.x[b.particle];
  std::ostringstream os;
  os << "simulation unstable at step " << sim.step_count << " (t = " << sim.time << "): particle id "
     << sim.p.id[b.particle] << " went through wall " << b.plane + 1 << " (its centre at (" << x.x() << ", " << x.y()
     << ", " << x.z() << "), height " << b.height << "). Likely cause: " << sim.stability_hint << ".";
  throw UnstableError(os.str());
}

template <class Sim>
RunReport run_impl(const ParticlesScene& s, Sim& sim, H5Output* out, bool progress) {
  const HealthLimits health = particles_health<Sim>(s);
  health.apply(sim);
  const long total = s.steps_per(s.duration);
  // Frame times are multiples of the interval, each rounded to the nearest
  // step, so they do not drift; the final state is always written.
  long snap_k = 0;
  auto due = [&] {
    if (sim.step_count < s.steps_per(snap_k * s.snapshot_every)) return false;
    while (s.steps_per(snap_k * s.snapshot_every) <= sim.step_count) ++snap_k;
    return true;
  };
  auto observe = [&](bool final_step) {
    ScopedPhase ph(sim.timers, Phase::observe);
    if (due() || final_step) {
      check_sides(sim);
      if (out) out->frame(sim.time, sim.step_count, sim.p);
    }
  };
  observe(false);
  const auto t0 = start_loop(sim, out);
  auto last_print = t0;
  const long n = static_cast<long>(sim.p.size());
  // The steps between two that observe, check or report run in one go.
  auto acts = [&](long k, double) {
    return k % health.every == 0 || s.steps_per(snap_k * s.snapshot_every) <= k || (progress && k % 200 == 0);
  };
  // The XDMF description (io/xdmf.hpp) is rewritten where the run ends: at its
  // last step, on SIGINT or SIGTERM, or when it stops unstable.
  run_loop(out, progress, [&] {
    for (long k = 0; k < total;) {
      const long next = next_stop(k, sim.time, sim.integrator.dt, total, acts);
      sim.advance(next - k);
      k = next;
      const bool fin = k == total;
      if (k % health.every == 0 || fin) {
        check_health(sim, health);
        check_sides(sim);
      }
      observe(fin);
      if (const int sig = stop_signal())
        throw Interrupted(std::string(sig == SIGINT ? "SIGINT" : "SIGTERM") + " at step " + std::to_string(k) +
                              " (t = " + std::to_string(sim.time) + "); a particles run keeps no checkpoint",
                          sig);
      if (progress && (k % 200 == 0 || fin)) {
        const auto now = std::chrono::steady_clock::now();
        if (now - last_print > std::chrono::milliseconds(500) || fin) {
          last_print = now;
          const double el = std::chrono::duration<double>(now - t0).count();
          std::fprintf(stderr, "\r  t = %.4g / %.4g   %.3g particle-steps/s   ", sim.time, s.duration,
                       el > 0 ? static_cast<double>(k) * n / el : 0.0);
          std::fflush(stderr);
        }
      }
    }
  });
  return run_report(sim, total, t0);
}

}  // namespace

ParticlesSim make_particles(const ParticlesScene& s) {
  ParticlesSim sim;
  const bool known = with_law(RapaportSceneLaws<MappingInputs>{}, s.law, Damping::normal, [&](auto tag) {
    sim.emplace<ParticlesSimT<typename decltype(tag)::type>>();
  });
  if (!known) throw std::logic_error("make_particles: contact.law \"" + s.law + "\" is not a registered law");
  std::visit([&](auto& v) { configure(v, s); }, sim);
  return sim;
}

RunReport run_particles(const ParticlesScene& s, ParticlesSim& sim, H5Output* out, bool progress) {
  return std::visit([&](auto& v) { return run_impl(s, v, out, progress); }, sim);
}

}  // namespace granular
