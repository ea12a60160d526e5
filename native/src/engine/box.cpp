#include "engine/box.hpp"

#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "engine/run_control.hpp"
#include "engine/run_members.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <sstream>
#include <type_traits>

namespace granular {

namespace {

template <class Sim>
constexpr bool kSmooth = Sim::template kHasWall<FlatBoxWalls>;  // no wall particles

template <class Sim>
void configure(Sim& sim, const BoxScene& s) {
  std::vector<Eigen::Vector2d> anchors;
  double top = 0.0;  // the side walls' top centre (particle or smooth)
  sim.p = box_particles(s, anchors, &top);
  const double xw = 0.5 * s.width + s.wall_radius;
  sim.domain.lo = Eigen::Vector2d(-xw - s.wall_radius - 1.0, -2.0 * s.wall_radius - s.amplitude - 1.0);
  sim.domain.hi = Eigen::Vector2d(xw + s.wall_radius + 1.0, top + 50.0);
  sim.domain.periodic = {false, false};
  sim.domain.finalize();
  sim.law = std::decay_t<decltype(sim.law)>::from_box(s);  // contact/laws.hpp
  sim.integrator.dt = s.dt;
  sim.integrator.gravity = Eigen::Vector2d(0.0, -s.gravity);  // F = -m g y^
  ShakerMotion<2> m;
  m.amplitude = s.amplitude;
  m.f0 = s.frequency;
  m.f1 = s.ramp_to;
  m.start = s.settle;
  m.ramp_start = s.ramp_start;
  m.ramp_time = s.ramp_time;
  m.startup_cycles = s.startup_cycles;
  if constexpr (kSmooth<Sim>) {
    FlatBoxWalls& w = std::get<FlatBoxWalls>(sim.walls);
    w.half_width = 0.5 * s.width;
    w.wall_radius = s.wall_radius;
    w.wall_inv_mass = s.wall_infinite_mass ? 0.0 : 1.0 / s.mass(s.wall_radius);  // as add_wall's particles
    w.side_top = top;
    w.shaker = m;
  } else {
    m.anchor = anchors;
    sim.integrator.motion = m;
    sim.exclude_species = kWallSpecies;  // wall particles do not interact with each other
  }
  sim.skin = s.skin;
  if (!s.rotation) sim.p.freeze_rotation();
  sim.init();
}

// The side walls' top surface at rest.
template <class Sim>
double wall_top(const Sim& sim, const BoxScene& s) {
  if constexpr (kSmooth<Sim>) {
    return std::get<FlatBoxWalls>(sim.walls).side_top + s.wall_radius;
  } else {
    double top = -INFINITY;  // highest side-wall particle's top
    for (const auto& a : sim.integrator.motion.anchor) top = std::max(top, a.y() + s.wall_radius);
    return top;
  }
}

template <class Sim>
void check_contained(const Sim& sim, const BoxScene& s) {
  const auto& m = shaker_of(sim);
  const double xw = 0.5 * s.width + s.wall_radius, floor = m.y(sim.time);
  for (std::size_t i = 0; i < sim.p.size(); ++i) {
    if (sim.p.species[i] == kWallSpecies) continue;
    const auto& x = sim.p.x[i];
    if (std::abs(x.x()) > xw || x.y() < floor - s.wall_radius || !std::isfinite(x.squaredNorm())) {
      std::ostringstream os;
      const double top = wall_top(sim, s) + m.y(sim.time);
      os << "grain id " << sim.p.id[i] << " escaped the box at t = " << sim.time << " s, position (" << x.x()
         << ", " << x.y() << ") cm";
      if (std::abs(x.x()) > xw && x.y() > top - 2.0 * s.radius_max)
        os << ": it flew over a side wall (top at y = " << top
           << " cm); raise box.wall_height or shake less hard (shaking.frequency, shaking.amplitude)";
      else if (kSmooth<Sim>)
        os << ": it passed through the smooth walls (box.walls = \"smooth\"); reduce integrator.dt ("
           << sim.stability_hint << ")";
      else
        os << ": it passed through the walls; close the wall-particle gaps (box.wall_spacing) or reduce "
              "integrator.dt (" << sim.stability_hint << ")";
      throw UnstableError(os.str());
    }
  }
}

template <class Sim>
std::size_t big_index(const Sim& sim) {
  for (std::size_t i = 0; i < sim.p.size(); ++i)
    if (sim.p.species[i] == 1) return i;
  return sim.p.size();
}

// What the box can drive (engine/health.hpp): the shaker's peak speed, free
// fall from the top of the walls; and the shortest contact, two of the
// lightest grains under Eq. (2): pi / sqrt(Y / m_eff - (gamma_N / 2)^2).
HealthLimits box_health(const BoxScene& s) {
  HealthLimits h;
  const double shaker = 2.0 * M_PI * std::max(s.frequency, s.ramp_to) * s.amplitude;
  const double fall = std::sqrt(2.0 * s.gravity * s.wall_height);
  h.max_speed = 8.0 * std::max(shaker, fall);
  std::ostringstream os;
  os << "shaker speed " << shaker << ", free fall from the top of the walls " << fall << ", x8";
  h.speed_sources = os.str();
  h.dt = s.dt;
  const double m_eff = 0.5 * s.mass(s.radius_min), w2 = s.young / m_eff - 0.25 * s.gamma_n * s.gamma_n;
  h.contact_period = w2 > 0 ? M_PI / std::sqrt(w2) : 0.0;
  return h;
}

// The run loop of one box (driver null: stepped by its simulation) or of
// several stepped by a driver (replicas: one scene, other seeds), all on the
// first member's schedule: the members share the time, so their frames and
// trace rows fall at the same steps. The driver is asked for a member's state
// where the loop observes, checks or checkpoints it.
template <class Sim>
RunReport run_impl(const BoxScene& s, std::vector<BoxMember>& ms, RunDriver* driver, bool progress) {
  const std::size_t members = ms.size();
  const std::vector<Sim*> sims = member_sims<Sim>(ms, "run_boxes");
  const HealthLimits health = box_health(s);
  for (Sim* v : sims) health.apply(*v);
  const long total = std::lround((s.settle + s.duration) / s.dt);
  const long settle_steps = std::lround(s.settle / s.dt);
  struct Counters {
    long snap_k = 0, trace_k = 0;
    int trace_h = -1, census_h = -1;
    bool has_big = false;
  };
  std::vector<Counters> cs(members);
  for (std::size_t r = 0; r < members; ++r) {
    H5Output* out = ms[r].out;
    Counters& c = cs[r];
    c.has_big = big_index(*sims[r]) < sims[r]->p.size();
    if (out && c.has_big)
      c.trace_h = out->init_series(
          "trace", {{"time", 1}, {"cycle", 1}, {"box_y", 1}, {"big_position", 2}, {"big_velocity", 2}});
    if (out) c.census_h = init_census(*out, decltype(Sim::law)::kSpecies);
  }
  auto observe = [&](std::size_t r, bool force_frame) {
    Sim& v = *sims[r];
    H5Output* out = ms[r].out;
    Counters& cr = cs[r];
    ScopedPhase ph(v.timers, Phase::observe);
    const double c = s.cycle(v.time);
    const bool shaking = v.step_count > settle_steps;
    bool snap = force_frame, trace = false;
    if (shaking && c >= (cr.snap_k + 1) * s.snapshot_every_cycles) {
      snap = true;
      cr.snap_k = static_cast<long>(std::floor(c / s.snapshot_every_cycles));
    }
    if (shaking && c * s.trace_per_cycle >= cr.trace_k + 1) {
      trace = true;
      cr.trace_k = static_cast<long>(std::floor(c * s.trace_per_cycle));
    }
    if (driver && (snap || trace)) driver->fetch(r);
    if (snap || trace) check_contained(v, s);
    if (out && snap) {
      out->frame(v.time, v.step_count, v.p);
      write_census(*out, cr.census_h, v.time, driver ? driver->census(r) : coulomb_census(v));
    }
    if (out && trace && cr.has_big) {
      const std::size_t b = big_index(v);
      out->series(cr.trace_h, {{v.time}, {c}, {shaker_of(v).y(v.time)},
                  {v.p.x[b].x(), v.p.x[b].y()}, {v.p.v[b].x(), v.p.v[b].y()}});
    }
  };
  auto part = make_run_part(
      "shaken-box", 500, [&](std::size_t r) { return std::array<long*, 2>{&cs[r].snap_k, &cs[r].trace_k}; },
      [&](std::size_t r) { observe(r, true); },
      [&](std::size_t r, long k) { observe(r, k == settle_steps || k == total); },
      // a frame or a trace row due at the step's cycle
      [&](long k, double t) {
        if (k == settle_steps) return true;
        if (k < settle_steps) return false;
        const Counters& c0 = cs.front();
        const double c = s.cycle(t);
        return c >= (c0.snap_k + 1) * s.snapshot_every_cycles || c * s.trace_per_cycle >= c0.trace_k + 1;
      },
      [&](Sim& v) { check_box_health(v, health); },
      [&](const Sim& v, double rate, double left) {
        std::fprintf(stderr, "\r  t = %.2f / %.2f s (%s)   %.3g particle-steps/s   %.0f s left   ", v.time,
                     s.settle + s.duration, v.step_count <= settle_steps ? "settling" : "shaking", rate, left);
      });
  return run_members(ms, sims, driver, progress, total, health, part);
}

// The scene's choices, one at a time, down to one alternative of BoxSim.
template <class Law, template <int, class> class Integrator>
void emplace_walls(BoxSim& sim, const BoxScene& s) {
  if (s.smooth_walls)
    sim.emplace<SmoothBoxOf<Law, Integrator>>();
  else
    sim.emplace<ParticleWallBoxOf<Law, Integrator>>();
}

template <class Law>
void emplace_integrator(BoxSim& sim, const BoxScene& s) {
  if (s.integrator == "gear")
    emplace_walls<Law, Gear5>(sim, s);
  else
    emplace_walls<Law, Leapfrog>(sim, s);
}

}  // namespace

BoxSim make_box(const BoxScene& s) {
  BoxSim sim;
  const bool known = with_law(BoxLaws{}, s.law, s.damping, [&](auto tag) {
    emplace_integrator<typename decltype(tag)::type>(sim, s);
  });
  if (!known)
    throw std::logic_error("make_box: contact.law \"" + s.law + "\" with contact.damping \"" +
                           damping_name(s.damping) + "\" is not a registered box law");
  std::visit([&](auto& v) { configure(v, s); }, sim);
  return sim;
}

RunReport run_box(const BoxScene& s, BoxSim& sim, H5Output* out, bool progress, const RunControl& ctl) {
  std::vector<BoxMember> ms{{&sim, out, ctl}};
  return std::visit([&](auto& v) { return run_impl<std::decay_t<decltype(v)>>(s, ms, nullptr, progress); }, sim);
}

RunReport run_box(const BoxScene& s, BoxSim& sim, H5Output* out, bool progress, const RunControl& ctl,
                  RunDriver& driver) {
  std::vector<BoxMember> ms{{&sim, out, ctl}};
  return run_boxes(s, ms, driver, progress);
}

RunReport run_boxes(const BoxScene& s, std::vector<BoxMember>& members, RunDriver& driver, bool progress) {
  if (members.empty()) throw std::logic_error("run_boxes: no member");
  return std::visit([&](auto& v) { return run_impl<std::decay_t<decltype(v)>>(s, members, &driver, progress); },
                    *members.front().sim);
}

BoxSim settle_box(const BoxScene& s, double settle) {
  BoxScene a = s;
  a.settle = settle;
  a.duration = 0.0;
  BoxSim sim = make_box(a);
  run_box(a, sim, nullptr, false);
  return sim;
}

RunReport time_box(const BoxScene& s, BoxSim& sim, double seconds) {
  return std::visit(
      [&](auto& v) {
        const long steps = std::lround(seconds / s.dt);
        v.timers.reset();
        const long builds0 = v.neighbors().builds();
        const auto t0 = std::chrono::steady_clock::now();
        v.advance(steps);
        RunReport r;
        r.steps = steps;
        r.particles = static_cast<long>(v.p.size());
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        r.particle_steps_per_second = steps * static_cast<double>(v.p.size()) / r.seconds;
        r.breakdown = step_breakdown(v, r.seconds, steps);
        r.neighbor_builds = v.neighbors().builds() - builds0;
        return r;
      },
      sim);
}

}  // namespace granular
