// Two-sphere head-on collision with the Rapaport law: restitution coefficient
// and contact duration from the engine against an independent RK4 integration
// of the same two-body equation with a tiny step.
#include <gtest/gtest.h>

#include "helpers.hpp"

using namespace granular;
using namespace granular::test;

namespace {

struct Outcome {
  double restitution;
  double duration;
};

// Relative coordinate r, reduced mass mu: mu r'' = f_v(r) - gamma_n r'
// (Eqs. (1), (2); for a head-on collision r^ . v_ij = dr/dt).
Outcome reference(double d1, double d2, double v0, double gamma_n) {
  const double m1 = d1 * d1 * d1, m2 = d2 * d2 * d2, mu = m1 * m2 / (m1 + m2);
  const double dij = 0.5 * (d1 + d2), rc = std::pow(2.0, 1.0 / 6.0) * dij;
  auto acc = [&](double r, double u) { return (lj_magnitude(r, dij) - gamma_n * u) / mu; };
  double r = rc, u = -v0, t = 0.0;
  const double h = 1e-7;
  while (true) {
    const double k1r = u, k1u = acc(r, u);
    const double k2r = u + 0.5 * h * k1u, k2u = acc(r + 0.5 * h * k1r, u + 0.5 * h * k1u);
    const double k3r = u + 0.5 * h * k2u, k3u = acc(r + 0.5 * h * k2r, u + 0.5 * h * k2u);
    const double k4r = u + h * k3u, k4u = acc(r + h * k3r, u + h * k3u);
    const double rn = r + h / 6 * (k1r + 2 * k2r + 2 * k3r + k4r);
    const double un = u + h / 6 * (k1u + 2 * k2u + 2 * k3u + k4u);
    if (rn >= rc && un > 0) {
      const double frac = (rc - r) / (rn - r);
      return {(u + frac * (un - u)) / v0, t + frac * h};
    }
    r = rn;
    u = un;
    t += h;
  }
}

Outcome engine(double d1, double d2, double v0, double gamma_n, double dt) {
  FreeSim sim;
  open_box(sim, 20.0);
  sim.law = Law3::from_paper(gamma_n, 10, 2, 10, 2, 0.5);
  sim.integrator.dt = dt;
  const double rc = Law3::range(d1, d2);
  const double gap = 1e-3;  // start just outside the range, approaching
  const double m1 = d1 * d1 * d1, m2 = d2 * d2 * d2;
  // Centre-of-mass frame: p1 = -p2.
  const double v1 = v0 * m2 / (m1 + m2), v2 = -v0 * m1 / (m1 + m2);
  add_sphere(sim, {-0.5 * (rc + gap), 0, 0}, {v1, 0, 0}, Eigen::Vector3d::Zero(), d1, 0);
  add_sphere(sim, {0.5 * (rc + gap), 0, 0}, {v2, 0, 0}, Eigen::Vector3d::Zero(), d2, 1);
  sim.init();
  auto sep = [&] {
    const auto a = sim.p.id[0] == 0 ? 0 : 1;
    return std::pair{(sim.p.x[1 - a] - sim.p.x[a]).x(), (sim.p.v[1 - a] - sim.p.v[a]).x()};
  };
  double t_in = -1, t_out = -1;
  auto [r_prev, u_prev] = sep();
  double t_prev = 0.0;
  while (t_out < 0) {
    sim.step();
    auto [r, u] = sep();
    if (t_in < 0 && r < rc) t_in = t_prev + (r_prev - rc) / (r_prev - r) * dt;
    if (t_in >= 0 && r >= rc) {
      t_out = t_prev + (rc - r_prev) / (r - r_prev) * dt;
      // Speed after the contact ends: no force acts beyond rc.
      return {u / v0, t_out - t_in};
    }
    r_prev = r;
    u_prev = u;
    t_prev = sim.time;
    if (sim.time > 100) ADD_FAILURE() << "no separation";
  }
  return {};
}

}  // namespace

TEST(Collision, HeadOnEqualSpheresMatchReference) {
  omp_set_num_threads(1);
  const auto ref = reference(1.0, 1.0, 1.0, 5.0);
  const auto got = engine(1.0, 1.0, 1.0, 5.0, 2e-5);
  EXPECT_GT(ref.restitution, 0.05);
  EXPECT_LT(ref.restitution, 0.95);
  EXPECT_NEAR(got.restitution, ref.restitution, 1e-3 * ref.restitution);
  EXPECT_NEAR(got.duration, ref.duration, 1e-3 * ref.duration);
}

TEST(Collision, HeadOnBigSmallMatchReference) {
  omp_set_num_threads(1);
  const auto ref = reference(0.9, 1.25, 2.0, 5.0);
  const auto got = engine(0.9, 1.25, 2.0, 5.0, 2e-5);
  EXPECT_NEAR(got.restitution, ref.restitution, 1e-3 * ref.restitution);
  EXPECT_NEAR(got.duration, ref.duration, 1e-3 * ref.duration);
}

TEST(Collision, WithoutDampingIsElastic) {
  omp_set_num_threads(1);
  const auto got = engine(1.0, 1.0, 1.0, 0.0, 1e-4);
  EXPECT_NEAR(got.restitution, 1.0, 1e-6);
}

// At the production step (dt = 0.005) the leapfrog's velocity-dependent forces
// are evaluated with half-kicked velocities; the error is first order in dt.
// Bound it, so a regression in the integrator shows up, and record it.
TEST(Collision, ProductionStepErrorIsSmall) {
  omp_set_num_threads(1);
  const auto ref = reference(1.0, 1.0, 1.0, 5.0);
  const auto got = engine(1.0, 1.0, 1.0, 5.0, 0.005);
  RecordProperty("restitution_rel_error_dt0.005", std::to_string(std::abs(got.restitution / ref.restitution - 1)));
  RecordProperty("duration_rel_error_dt0.005", std::to_string(std::abs(got.duration / ref.duration - 1)));
  std::printf("dt=0.005: restitution %.6f (ref %.6f), duration %.6f (ref %.6f)\n", got.restitution, ref.restitution,
              got.duration, ref.duration);
  EXPECT_NEAR(got.restitution, ref.restitution, 0.05 * ref.restitution);
  EXPECT_NEAR(got.duration, ref.duration, 0.05 * ref.duration);
}
