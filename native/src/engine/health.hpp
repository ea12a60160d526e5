// Failure detection during a run, beyond the per-step check in
// Simulation::step() (a non-finite value, or a move longer than the neighbour
// list allows). Every `every` steps and at each output, over all particles and
// listed pairs:
//   - a non-finite position or velocity;
//   - (every step, in Simulation::step(), from max_speed set here) a speed
//     beyond anything the scene drives (the wall, the shaker, free fall over
//     the container; times a margin): energy growing without a source, the
//     signature of a time step too long for the contact period;
//   - an overlap beyond a fraction of the contact distance: contacts too soft
//     for the load, or a collision the time step did not resolve.
// Each stops the run with UnstableError naming the step, time, particle(s)
// and the likely cause, with the time step set against the contact period.
// (A particle outside the container is checked by each scene's run loop.)
#pragma once
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "engine/simulation.hpp"

namespace granular {

struct HealthLimits {
  template <class Sim>
  void apply(Sim& sim) const {  // the per-step parts
    sim.stability_hint = dt_hint();
    sim.max_speed = max_speed;
    sim.speed_sources = speed_sources;
  }

  long every = 100;            // steps between checks (and at each output)
  double max_speed = INFINITY; // speeds above this have no source in the scene
  std::string speed_sources;   // what sets max_speed, for the message
  double max_overlap = 0.4;    // as a fraction of the contact distance Law::range(d_i, d_j)
  double dt = 0.0;
  double contact_period = 0.0;  // shortest binary contact of the scene (0: unknown)
  // Rapaport's law: the contact at the fastest impact the scene can produce,
  // which sets the default step (scene/step_rule.hpp; 0: not used).
  double impact_speed = 0.0, impact_contact = 0.0, impact_steps_needed = 0.0;

  // "integrator.dt = 0.005 is 1/23 of the shortest contact period (0.115)..."
  std::string dt_hint() const {
    std::ostringstream os;
    if (contact_period > 0 && std::isfinite(contact_period)) {
      const double ratio = contact_period / dt;
      os << "integrator.dt = " << dt << " is 1/" << std::setprecision(ratio < 10 ? 2 : 4) << ratio
         << std::setprecision(6) << " of the shortest contact period (" << contact_period
         << "); runs stay accurate below about 1/20";
      if (impact_contact > 0) {
        const double k = impact_contact / dt;
        os << ", and 1/" << std::setprecision(k < 10 ? 2 : 4) << k << std::setprecision(6)
           << " of the contact at the fastest impact the scene can produce (" << impact_contact << " at speed "
           << impact_speed << "), which needs at least 1/" << impact_steps_needed
           << " (the default step keeps that)";
      }
    } else {
      os << "integrator.dt = " << dt;
    }
    return os.str();
  }
};

template <class Sim>
void check_health(const Sim& sim, const HealthLimits& lim) {
  const auto& p = sim.p;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double v2 = p.v[i].squaredNorm();
    if (!std::isfinite(v2) || !std::isfinite(p.x[i].squaredNorm()) || !std::isfinite(p.w[i].squaredNorm())) {
      std::ostringstream os;
      os << "simulation unstable at step " << sim.step_count << " (t = " << sim.time << "): particle id " << p.id[i]
         << " has a non-finite position or velocity. Likely cause: " << lim.dt_hint() << ".";
      throw UnstableError(os.str());
    }
  }
  const auto& nl = sim.neighbors();
  using Law = std::decay_t<decltype(sim.law)>;
  double worst = lim.max_overlap;
  std::size_t wi = 0, wj = 0;
  bool found = false;
  for (int t = 0; t < nl.threads(); ++t) {
    const auto [lo, hi] = nl.row_block(t);
    const std::uint32_t* col = nl.col(t);
    for (std::size_t i = lo; i < hi; ++i)
      for (std::uint32_t k = nl.begin(i); k < nl.end(i); ++k) {
        const std::size_t j = col[k];
        const double rc = Law::range(p.d[i], p.d[j]);
        const double r = sim.domain.min_image(p.x[i] - p.x[j]).norm();
        const double ov = (rc - r) / rc;
        if (ov > worst) {
          worst = ov;
          wi = i;
          wj = j;
          found = true;
        }
      }
  }
  if (found) {
    std::ostringstream os;
    os << "simulation unstable at step " << sim.step_count << " (t = " << sim.time << "): particles id "
       << p.id[wi] << " and " << p.id[wj] << " overlap by " << 100.0 * worst
       << " % of their contact distance (limit " << 100.0 * lim.max_overlap
       << " %): the contacts are too soft for the load, or a collision was not resolved. Likely cause: "
       << lim.dt_hint() << ", or a contact stiffness too low for the weight it carries.";
    throw UnstableError(os.str());
  }
}

}  // namespace granular
