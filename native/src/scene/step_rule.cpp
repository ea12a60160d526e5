#include "scene/step_rule.hpp"

#include <algorithm>
#include <cmath>

#include "contact/rapaport.hpp"
#include "scene/box_scene.hpp"
#include "scene/drum_scene.hpp"
#include "scene/particles_scene.hpp"

namespace granular {

namespace {

// Rounded down to two significant digits, so a default step reads as it is used.
double round_down_2(double x) {
  const double scale = std::pow(10.0, std::floor(std::log10(x)) - 1.0);
  const double digits = std::floor(x / scale * (1.0 + 1e-12));
  return scale < 1.0 ? digits / std::round(1.0 / scale) : digits * scale;
}

StepRule finish(StepRule r) {
  const double contact_step = r.contact_time / r.steps_per_contact;
  r.binding = contact_step < r.accuracy_step ? "contact" : "accuracy";
  r.dt = r.binding == "contact" ? round_down_2(contact_step) : r.accuracy_step;
  return r;
}

}  // namespace

double rapaport_contact_bound(double dij, double meff, double gamma_n, double v) {
  const double rc = RapaportLaw<3>::kCutFactor * dij;
  auto acc = [&](double r, double u) { return RapaportLaw<3>::normal(1.0 / r, dij, u, gamma_n) / meff; };
  // Classical RK4 at 1/50 000 of the time to cross d_ij at the impact speed;
  // the turning point is found by linear interpolation of r' in the last step.
  const double h = 2e-5 * dij / v;
  double r = rc, u = -v, t = 0.0;
  for (long k = 0; k < 10000000L; ++k) {
    const double k1r = u, k1u = acc(r, u);
    const double k2r = u + 0.5 * h * k1u, k2u = acc(r + 0.5 * h * k1r, u + 0.5 * h * k1u);
    const double k3r = u + 0.5 * h * k2u, k3u = acc(r + 0.5 * h * k2r, u + 0.5 * h * k2u);
    const double k4r = u + h * k3u, k4u = acc(r + h * k3r, u + h * k3u);
    const double un = u + h / 6 * (k1u + 2 * k2u + 2 * k3u + k4u);
    if (un >= 0.0) return 2.0 * (t + h * (-u) / (un - u));
    r += h / 6 * (k1r + 2 * k2r + 2 * k3r + k4r);
    u = un;
    t += h;
  }
  return 2.0 * t;  // not turned within 2e8 d_ij / v (cannot happen: f_v diverges)
}

StepRule drum_step_rule(const DrumScene& s) {
  StepRule r;
  r.accuracy_step = kDrumAccuracyStep;
  r.steps_per_contact = kDrumStepsPerContact;
  r.impact_speed = std::max({std::sqrt(2.0 * s.gravity * s.diameter) + std::abs(s.omega) * 0.5 * s.diameter,
                             s.initial_speed, 1e-3});
  const double d = std::max(s.small_diameter - s.diameter_spread, 1e-3 * s.small_diameter);  // lightest grain
  const double m = d * d * d;  // m_i = d_i^3 (Sec. III)
  r.contact_time = std::min(rapaport_contact_bound(d, 0.5 * m, s.gamma_n, r.impact_speed),
                            rapaport_contact_bound(0.5 * (d + s.wall_diameter), m, s.gamma_n, r.impact_speed));
  return finish(r);
}

StepRule particles_step_rule(const ParticlesScene& s) {
  StepRule r;
  r.accuracy_step = kDrumAccuracyStep;
  r.steps_per_contact = kDrumStepsPerContact;
  const double v = s.max_speed + s.release_speed + std::sqrt(2.0 * s.gravity * s.height);
  r.impact_speed = std::max(2.0 * v, 1e-3);  // two particles head-on
  const double d = s.d_min, m = d * d * d;   // the lightest particle, m_i = d_i^3 (Sec. III)
  r.contact_time = rapaport_contact_bound(d, 0.5 * m, s.gamma_n, r.impact_speed);
  if (!s.walls.empty())
    r.contact_time = std::min(r.contact_time, rapaport_contact_bound(0.5 * (d + s.wall_diameter), m, s.gamma_n,
                                                                     std::max(v, 1e-3)));
  return finish(r);
}

StepRule box_step_rule(const BoxScene& s) {
  StepRule r;
  r.accuracy_step = kBoxAccuracyStep;
  r.steps_per_contact = kBoxStepsPerContact;
  const double m_eff = 0.5 * s.mass(s.radius_min), w2 = s.young / m_eff - 0.25 * s.gamma_n * s.gamma_n;
  // Overdamped pairs do not oscillate: their stiffest rate sqrt(Y/m_eff) sets the step.
  r.contact_time = M_PI / std::sqrt(w2 > 0 ? w2 : s.young / m_eff);
  return finish(r);
}

}  // namespace granular
