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

Outcome engine(double d1, double d2, double v0, double gamma_n, double dt, double gap = 1e-3) {
  FreeSim sim;
  open_box(sim, 20.0);
  sim.law = Law3::from_paper(gamma_n, 10, 2, 10, 2, 0.5);
  sim.integrator.dt = dt;
  const double rc = Law3::range(d1, d2);
  // start just outside the range (by gap), approaching
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

// Accuracy against the step size. The damping force of Eq. (2) switches on
// and off discontinuously at the cutoff, and velocity-dependent forces are
// evaluated with the half-kicked velocity (Rapaport's leapfrog), so the error
// is first order in dt with a coefficient that depends on where in a step the
// contact begins and ends. Averaged over 16 entry phases, the error must fall
// at least 1.6-fold per halving of dt (measured 1.7-2.3). At the production
// step dt = 0.005 the restitution error was measured at 2.8 % on average and
// 7.6 % for the worst phase, the duration error at 0.7 % and 1.1 %
// (docs/accuracy.md); the bounds below sit about 20 % above those figures, to
// flag a regression of the integrator, not to describe the model.
TEST(Collision, ConvergesWithStep) {
  omp_set_num_threads(1);
  const auto ref = reference(1.0, 1.0, 1.0, 5.0);
  double prev_e = 0.0, prev_t = 0.0;
  for (double dt : {0.01, 0.005, 0.0025, 0.00125, 0.000625}) {
    double sum_e = 0, sum_t = 0, max_e = 0, max_t = 0;
    const int phases = 16;
    for (int k = 0; k < phases; ++k) {
      const auto got = engine(1.0, 1.0, 1.0, 5.0, dt, dt * (k + 0.5) / phases);
      const double err_e = std::abs(got.restitution / ref.restitution - 1);
      const double err_t = std::abs(got.duration / ref.duration - 1);
      sum_e += err_e / phases;
      sum_t += err_t / phases;
      max_e = std::max(max_e, err_e);
      max_t = std::max(max_t, err_t);
    }
    std::printf("dt=%-9g restitution error mean %.2e max %.2e   duration error mean %.2e max %.2e\n", dt, sum_e,
                max_e, sum_t, max_t);
    if (dt == 0.005) {
      EXPECT_LT(sum_e, 0.034);
      EXPECT_LT(max_e, 0.09);
      EXPECT_LT(sum_t, 0.008);
      EXPECT_LT(max_t, 0.014);
    }
    if (prev_e > 0) {
      EXPECT_GT(prev_e / sum_e, 1.6) << "dt " << dt;
      EXPECT_GT(prev_t / sum_t, 1.6) << "dt " << dt;
    }
    prev_e = sum_e;
    prev_t = sum_t;
  }
}
