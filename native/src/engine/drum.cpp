#include "engine/drum.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>

#include "engine/contact_setup.hpp"
#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "engine/run_control.hpp"
#include "engine/run_members.hpp"
#include "scene/law_mapping.hpp"
#include "scene/step_rule.hpp"

namespace granular {

namespace {

template <class Sim>
void configure_common(Sim& sim, const DrumScene& s) {
  sim.p = drum_particles(s);
  const WallGeometry wg = set_contact_law(sim, mapping_inputs(s), s.kappa);
  const double d_wall = wg.d_wall, inset = wg.inset;
  const double half_d = 0.5 * s.diameter, margin = 2.0;
  sim.domain.lo = Eigen::Vector3d(-half_d - margin, -0.5 * s.length, -half_d - margin);
  sim.domain.hi = Eigen::Vector3d(half_d + margin, 0.5 * s.length, half_d + margin);
  sim.domain.periodic = {false, !s.capped, false};
  if (s.capped) {
    sim.domain.lo.y() -= margin;
    sim.domain.hi.y() += margin;
  }
  sim.domain.finalize();
  sim.integrator.dt = s.dt;
  sim.integrator.gravity = Eigen::Vector3d(0.0, 0.0, -s.gravity);  // g along -z (Sec. III)
  sim.skin = s.skin;
  CylinderWall& cyl = std::get<CylinderWall>(sim.walls);
  cyl.diameter = s.diameter - 2.0 * inset;
  cyl.omega = s.omega;
  cyl.d_wall = d_wall;
  const bool paper = s.wall_lever == "paper";
  cyl.lever = WallLever{paper ? 1.0 : 0.0, paper ? 0.0 : 1.0};
  if constexpr (Sim::template kHasWall<EndCaps>) {
    EndCaps& caps = std::get<EndCaps>(sim.walls);
    caps.length = s.length - 2.0 * inset;
    caps.omega = s.omega;
    caps.d_wall = d_wall;
    caps.lever = cyl.lever;
  }
  if (!s.rotation) sim.p.freeze_rotation();
  sim.init();
}

std::string format_duration(double sec) {
  char buf[64];
  const long s = std::lround(sec);
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", s / 3600, (s / 60) % 60);
  else
    std::snprintf(buf, sizeof buf, "%ldm%02lds", s / 60, s % 60);
  return buf;
}

std::vector<double> slice_edges(const DrumScene& s) {
  const int ns = std::max(1, static_cast<int>(std::lround(s.length / s.profile_slice_width)));
  std::vector<double> e(ns + 1);
  for (int k = 0; k <= ns; ++k) e[k] = -0.5 * s.length + s.length * k / ns;
  return e;
}

template <class Sim>
void check_inside(const Sim& sim, const DrumScene& s) {
  const double lim = 0.5 * s.diameter + 0.5;
  for (std::size_t i = 0; i < sim.p.size(); ++i) {
    const auto& x = sim.p.x[i];
    if (x.x() * x.x() + x.z() * x.z() > lim * lim || (s.capped && std::abs(x.y()) > 0.5 * s.length + 0.5)) {
      std::ostringstream os;
      os << "simulation unstable at step " << sim.step_count << " (t = " << sim.time << "): particle id "
         << sim.p.id[i] << " left the drum at (" << x.x() << ", " << x.y() << ", " << x.z()
         << "). Reduce integrator.dt or check the wall parameters.";
      throw UnstableError(os.str());
    }
  }
}

// What the drum can drive (engine/health.hpp): the wall's speed, free fall
// across the drum, the initial and matching speeds; and the shortest contact.
template <class Sim>
HealthLimits drum_health(const DrumScene& s) {
  HealthLimits h;
  const double wall = std::abs(s.omega) * 0.5 * s.diameter, fall = std::sqrt(2.0 * s.gravity * s.diameter);
  const double v = std::max({wall, fall, s.initial_speed, s.impact_speed});
  h.max_speed = 8.0 * v;
  std::ostringstream os;
  os << "wall speed " << wall << ", free fall across the drum " << fall << ", x8";
  h.speed_sources = os.str();
  h.dt = s.dt;
  try {
    const LinearMapping m = map_rapaport_to_linear(s);
    constexpr bool rapaport = std::is_same_v<decltype(Sim::law), RapaportLaw<3>>;
    double t = INFINITY;
    for (int k = 0; k < 3; ++k) t = std::min(t, (rapaport ? m.pair_collision[k] : m.pair_linear[k]).contact_time);
    for (int a = 0; a < 2; ++a) t = std::min(t, (rapaport ? m.wall_collision[a] : m.wall_linear[a]).contact_time);
    h.contact_period = t;
    const StepRule r = drum_step_rule(s);
    if (rapaport) {
      h.impact_speed = r.impact_speed;
      h.impact_contact = r.contact_time;
      h.impact_steps_needed = r.steps_per_contact;
    } else {
      // The linear and viscoelastic springs (the same k_n, docs/model_mapping.md)
      // let an impact overlap in proportion to its speed, where Rapaport's force
      // stiffens without bound. At the scene's fastest impact (the initial
      // collapse) they can exceed the 40 % that flags an instability under
      // Rapaport's law (#A at L = 32: 42 % at every step, seed 7): the limit is
      // 1.25 times the undamped head-on overlap at that speed, at most half the
      // contact distance (beyond it the spring is too soft for the scene: a fast
      // drum still stops, docs/stability.md).
      const double worst = linear_overlap_fraction(mapping_inputs(s), m, r.impact_speed);
      h.max_overlap = std::min(0.5, std::max(h.max_overlap, 1.25 * worst));
    }
  } catch (const MappingError&) {
    h.contact_period = 0.0;  // overdamped: no period to quote
  }
  return h;
}

// The run loop of one drum (driver null: stepped by its simulation) or of
// several stepped by a driver, all on the first member's schedule.
template <class Sim>
RunReport run_impl(const DrumScene& s, std::vector<DrumMember>& ms, RunDriver* driver, bool progress) {
  const std::size_t members = ms.size();
  const std::vector<Sim*> sims = member_sims<Sim>(ms, "run_drums");
  const HealthLimits health = drum_health<Sim>(s);
  for (Sim* v : sims) health.apply(*v);
  const long total = s.steps_per(s.rotations);
  const auto edges = slice_edges(s);
  const double period = s.rotation_period();
  // Output times are multiples of the interval in rotations, each rounded to
  // the nearest step, so they do not drift; the final state is always written.
  struct Counters {
    long snap_k = 0, prof_k = 0;
    int census = -1;
  };
  std::vector<Counters> cs(members);
  const std::vector<long> final_frames = s.final_snapshot_steps();
  auto final_frame = [&](long k) { return std::binary_search(final_frames.begin(), final_frames.end(), k); };
  auto due = [&](const Sim& v, long& k, double every) {
    if (v.step_count < s.steps_per(k * every)) return false;
    while (s.steps_per(k * every) <= v.step_count) ++k;
    return true;
  };
  for (std::size_t r = 0; r < members; ++r)
    cs[r].census = ms[r].out ? init_census(*ms[r].out, decltype(Sim::law)::kSpecies) : -1;
  auto observe = [&](std::size_t r, bool final_step) {
    Sim& v = *sims[r];
    H5Output* out = ms[r].out;
    Counters& c = cs[r];
    ScopedPhase ph(v.timers, Phase::observe);
    const bool prof = due(v, c.prof_k, s.profile_every) || final_step;
    const bool snap = due(v, c.snap_k, s.snapshot_every) || final_step || final_frame(v.step_count);
    if (driver && (prof || (out && snap))) driver->fetch(r);
    if (prof) {
      check_inside(v, s);
      if (out) {
        out->profile(v.time, axial_small_fraction(v.p, edges));
        write_census(*out, c.census, v.time, driver ? driver->census(r) : coulomb_census(v));
      }
    }
    if (out && snap) out->frame(v.time, v.step_count, v.p);
  };
  for (std::size_t r = 0; r < members; ++r)
    if (ms[r].out) ms[r].out->init_profile(edges);
  auto part = make_run_part(
      "drum", 200, [&](std::size_t r) { return std::array<long*, 2>{&cs[r].snap_k, &cs[r].prof_k}; },
      [&](std::size_t r) { observe(r, false); }, [&](std::size_t r, long k) { observe(r, k == total); },
      [&](long k, double) {
        const Counters& c = cs.front();
        return s.steps_per(c.prof_k * s.profile_every) <= k || s.steps_per(c.snap_k * s.snapshot_every) <= k ||
               final_frame(k);
      },
      [&](Sim& v) { check_health(v, health); },
      [&](const Sim& v, double rate, double left) {
        std::fprintf(stderr, "\r  rotation %.2f / %.2f   %.3g particle-steps/s   %s left   ", v.time / period,
                     s.rotations, rate, format_duration(left).c_str());
      });
  return run_members(ms, sims, driver, progress, total, health, part);
}

}  // namespace

DrumSim make_drum(const DrumScene& s) {
  DrumSim sim;
  const bool known = with_law(DrumLaws{}, s.law, Damping::normal, [&](auto tag) {
    using Law = typename decltype(tag)::type;
    if (s.capped)
      sim.emplace<DrumCappedT<Law>>();
    else
      sim.emplace<DrumPeriodicT<Law>>();
  });
  if (!known) throw std::logic_error("make_drum: contact.law \"" + s.law + "\" is not a registered drum law");
  std::visit([&](auto& v) { configure_common(v, s); }, sim);
  return sim;
}

std::vector<double> axial_small_fraction(const ParticleStore<3>& p, const std::vector<double>& edges) {
  const std::size_t ns = edges.size() - 1;
  std::vector<double> small(ns, 0.0), all(ns, 0.0);
  const double lo = edges.front(), width = (edges.back() - edges.front()) / ns;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double y = p.x[i].y();
    long k = static_cast<long>(std::floor((y - lo) / width));
    k = std::clamp<long>(k, 0, static_cast<long>(ns) - 1);
    // Settle rounding at the edges exactly: edges[k] <= y < edges[k+1].
    if (k > 0 && y < edges[k]) --k;
    if (k + 1 < static_cast<long>(ns) && y >= edges[k + 1]) ++k;
    const double vol = p.d[i] * p.d[i] * p.d[i];
    all[k] += vol;
    if (p.species[i] == 0) small[k] += vol;
  }
  for (std::size_t k = 0; k < ns; ++k)
    small[k] = all[k] > 0 ? small[k] / all[k] : std::numeric_limits<double>::quiet_NaN();
  return small;
}

RunReport run_drum(const DrumScene& s, DrumSim& sim, H5Output* out, bool progress, const RunControl& ctl) {
  std::vector<DrumMember> ms{{&sim, out, ctl}};
  return std::visit(
      [&](auto& v) { return run_impl<std::decay_t<decltype(v)>>(s, ms, nullptr, progress); }, sim);
}

RunReport run_drums(const DrumScene& s, std::vector<DrumMember>& members, RunDriver& driver, bool progress) {
  if (members.empty()) throw std::logic_error("run_drums: no member");
  return std::visit(
      [&](auto& v) { return run_impl<std::decay_t<decltype(v)>>(s, members, &driver, progress); },
      *members.front().sim);
}

DrumSim settle_drum(const DrumScene& s, double settle) {
  DrumScene a = s;
  a.rotations = settle;
  a.snapshot_every = a.profile_every = 1e9;
  DrumSim sim = make_drum(a);
  if (settle > 0) run_drum(a, sim, nullptr, false);
  return sim;
}

RunReport time_drum(const DrumScene& s, DrumSim& sim, double rotations) {
  DrumScene a = s;
  a.rotations = rotations;
  a.snapshot_every = a.profile_every = 1e9;
  const long builds0 = std::visit([](auto& v) { return v.neighbors().builds(); }, sim);
  RunReport r = run_drum(a, sim, nullptr, false);
  std::visit([&](auto& v) {
    r.breakdown = step_breakdown(v, r.seconds, r.steps);
    r.neighbor_builds = v.neighbors().builds() - builds0;
  }, sim);
  return r;
}

}  // namespace granular
