// The drum's curved wall and end caps (Rapaport 2002, Sec. III, Eq. (5)).
#include <gtest/gtest.h>

#include <stdexcept>
#include <utility>
#include <variant>

#include "engine/box.hpp"
#include "engine/drum.hpp"
#include "helpers.hpp"

using namespace granular;
using namespace granular::test;

namespace {

constexpr double kD = 16.0, kL = 16.0, kG = 5.0;

// Periodic drum section with the curved wall only.
CylSim drum(double omega, const std::string& lever = "paper") {
  CylSim sim;
  sim.domain.lo = Eigen::Vector3d(-kD / 2 - 2, -kL / 2, -kD / 2 - 2);
  sim.domain.hi = Eigen::Vector3d(kD / 2 + 2, kL / 2, kD / 2 + 2);
  sim.domain.periodic = {false, true, false};
  sim.domain.finalize();
  sim.law = Law3::from_paper(5.0, 10, 2, 10, 2, 0.5);  // small-wall: gamma 2, mu 0.1; big-wall: 10, 0.5
  sim.integrator.gravity = Eigen::Vector3d(0, 0, -kG);
  auto& w = std::get<CylinderWall>(sim.walls);
  w.diameter = kD;
  w.omega = omega;
  w.lever = lever == "paper" ? WallLever{1.0, 0.0} : WallLever{0.0, 1.0};
  return sim;
}

// Gap between particle centre and wall at which Eq. (1) with d_iw balances m g.
double resting_gap(double d) {
  const double d_iw = 0.5 * (d + 1.0), m = d * d * d;
  return bisect([&](double r) { return lj_magnitude(r, d_iw) - m * kG; }, 0.8 * d_iw,
                std::pow(2.0, 1.0 / 6.0) * d_iw);
}

}  // namespace

class RestingOnWall : public ::testing::TestWithParam<double> {};

TEST_P(RestingOnWall, SettlesWhereEq1BalancesWeight) {
  omp_set_num_threads(1);
  const double d = GetParam();
  auto sim = drum(0.0);
  add_sphere(sim, {0, 0, -(kD / 2 - 1.0)}, {0, 0, -0.5}, Eigen::Vector3d::Zero(), d, d > 1.1 ? 1 : 0);
  sim.init();
  for (int s = 0; s < 40000; ++s) sim.step();
  const double gap = kD / 2 - std::hypot(sim.p.x[0].x(), sim.p.x[0].z());
  const double ref = resting_gap(d);
  EXPECT_NEAR(gap, ref, 1e-9 * ref) << "d = " << d;
  EXPECT_LT(sim.p.v[0].norm(), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Sizes, RestingOnWall, ::testing::Values(0.8, 1.0, 1.3));

class SpinToRolling : public ::testing::TestWithParam<std::string> {};

// A sphere spinning about x on the bottom of a resting drum rolls off along the
// axis. Friction changes v and w in the fixed ratio I dw = R m dv, so the end
// state (sliding velocity zero) is w_f = w0 (I/Rm) / (I/Rm + l), v_y = -l w_f,
// with l the lever multiplying w in the sliding velocity.
TEST_P(SpinToRolling, ConvergesToRolling) {
  omp_set_num_threads(1);
  const std::string lever = GetParam();
  const double d = 1.0, w0 = 3.0;
  auto sim = drum(0.0, lever);
  const double gap = resting_gap(d);
  add_sphere(sim, {0, 0, -(kD / 2 - gap)}, Eigen::Vector3d::Zero(), {w0, 0, 0}, d, 0);
  sim.init();
  for (int s = 0; s < 4000; ++s) sim.step();
  const double m = 1.0, r = 0.5, inertia = 0.1;
  const double l = lever == "paper" ? gap : gap * d / (d + 1.0);
  const double wf = w0 * (inertia / (r * m)) / (inertia / (r * m) + l);
  EXPECT_NEAR(sim.p.w[0].x(), wf, 1e-8 * wf);
  EXPECT_NEAR(sim.p.v[0].y(), -l * wf, 1e-8 * l * wf);
  // and it is rolling: the model's sliding velocity vanishes
  EXPECT_NEAR(sim.p.v[0].y() + l * sim.p.w[0].x(), 0.0, 1e-10);
}

INSTANTIATE_TEST_SUITE_P(Levers, SpinToRolling, ::testing::Values("paper", "pair"));

// A resting sphere on a wall that starts rotating is dragged along at the
// rate of Eq. (5): capped at mu |f_n| = mu m g when the wall is fast.
TEST(WallFriction, CappedSlidingAccelerationIsMuG) {
  omp_set_num_threads(1);
  const double omega = 0.5, d = 1.0;
  auto sim = drum(omega);
  sim.integrator.dt = 0.001;
  add_sphere(sim, {0, 0, -(kD / 2 - resting_gap(d))}, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), d, 0);
  sim.init();
  const double mu = 0.1;  // small-wall: 0.5 * 2/10
  ASSERT_GT(2.0 * omega * kD / 2, mu * kG);  // gamma_s |v_s| > mu |f_n|: the cap binds
  for (int s = 0; s < 10; ++s) sim.step();
  // Wall velocity at the bottom is +x (s = (D/2) r^ x y^ with r^ = -z^).
  EXPECT_NEAR(sim.p.v[0].x(), mu * kG * sim.time, 1e-4 * mu * kG * sim.time);
  EXPECT_NEAR(sim.p.v[0].y(), 0.0, 1e-12);
}

// Slow wall: viscous regime. With s = v - u - l w the sliding velocity,
// ds/dt = -gamma (1/m + l R / I) s, so v_x(t) = (gamma/m) u/k (1 - e^{-kt}).
TEST(WallFriction, ViscousSlidingFollowsEq5) {
  omp_set_num_threads(1);
  const double omega = 0.01, d = 1.3;  // big particle: gamma_bw = 10, mu_bw = 0.5
  auto sim = drum(omega);
  sim.integrator.dt = 1e-5;
  const double gap = resting_gap(d);
  add_sphere(sim, {0, 0, -(kD / 2 - gap)}, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), d, 1);
  sim.init();
  const double m = d * d * d, r = d / 2, inertia = 0.1 * m * d * d, gamma = 10.0, u = omega * kD / 2;
  ASSERT_LT(gamma * u, 0.5 * m * kG);  // the cap does not bind
  for (int s = 0; s < 5000; ++s) sim.step();
  const double k = gamma * (1.0 / m + gap * r / inertia);
  const double expect = gamma / m * u / k * (1.0 - std::exp(-k * sim.time));
  EXPECT_NEAR(sim.p.v[0].x(), expect, 1e-3 * expect);
  // The spin it picked up: I w_y = -R m v_x (torque -R n x f_s), up to the
  // tangential part of gravity on the curved wall, which changes v_x but not w
  // by about g t^2 / (2 (D/2)) ~ 1e-3 relative at t = 0.05.
  const double w_expect = -r * m * sim.p.v[0].x() / inertia;
  EXPECT_NEAR(sim.p.w[0].y(), w_expect, 2e-3 * std::abs(w_expect));
}

// Direct force evaluation against the formulas of Sec. III written out here.
TEST(WallForce, CurvedWallSingleContact) {
  omp_set_num_threads(1);
  const double omega = 0.5, d = 1.3;
  auto sim = drum(omega);
  const double gap = 0.95, ang = 0.7;
  const Eigen::Vector3d rhat(std::sin(ang), 0, -std::cos(ang));
  const Eigen::Vector3d x = (kD / 2 - gap) * rhat + Eigen::Vector3d(0, 1.5, 0);
  const Eigen::Vector3d v(0.2, -0.1, 0.3), w(0.5, 1.0, -2.0);
  add_sphere(sim, x, v, w, d, 1);
  sim.init();  // computes forces
  const double d_iw = 0.5 * (d + 1.0);
  const Eigen::Vector3d n = -rhat;  // r'_iw: from the wall point towards the axis
  const Eigen::Vector3d s = (kD / 2) * rhat.cross(Eigen::Vector3d::UnitY());
  const Eigen::Vector3d viw = v - omega * s;
  const double fn = lj_magnitude(gap, d_iw) - 5.0 * n.dot(viw);
  const Eigen::Vector3d vs = viw - n.dot(viw) * n - w.cross(gap * n);
  const double fsm = std::min(10.0 * vs.norm(), 0.5 * std::abs(fn));
  const Eigen::Vector3d fs = -fsm * vs.normalized();
  const Eigen::Vector3d f = fn * n + fs;
  const Eigen::Vector3d tq = -(d / 2) * n.cross(fs);
  EXPECT_LT((sim.p.f[0] - f).norm(), 1e-12 * f.norm());
  EXPECT_LT((sim.p.tq[0] - tq).norm(), 1e-12 * tq.norm());
}

TEST(WallForce, NothingOutOfRange) {
  auto sim = drum(0.5);
  add_sphere(sim, {0, 0, -(kD / 2 - 1.2)}, {1, 0, 0}, {0, 1, 0}, 1.0, 0);  // 1.2 > 2^(1/6) * 1
  sim.init();
  EXPECT_EQ(sim.p.f[0].norm(), 0.0);
}

TEST(WallForce, EndCapSingleContact) {
  omp_set_num_threads(1);
  CapSim sim;
  sim.domain.lo = Eigen::Vector3d(-kD / 2 - 2, -kL / 2 - 2, -kD / 2 - 2);
  sim.domain.hi = Eigen::Vector3d(kD / 2 + 2, kL / 2 + 2, kD / 2 + 2);
  sim.domain.periodic = {false, false, false};
  sim.domain.finalize();
  sim.law = Law3::from_paper(5.0, 10, 2, 10, 2, 0.5);
  const double omega = 0.5;
  std::get<CylinderWall>(sim.walls).diameter = kD;
  std::get<CylinderWall>(sim.walls).omega = omega;
  std::get<EndCaps>(sim.walls).length = kL;
  std::get<EndCaps>(sim.walls).omega = omega;
  const double d = 1.0, gap = 0.93;
  for (int side : {+1, -1}) {
    sim.p = ParticleStore<3>();
    const Eigen::Vector3d x(3.0, side * (kL / 2 - gap), -2.0), v(0.1, 0.2, -0.3), w(0, 0, 0);
    add_sphere(sim, x, v, w, d, 0);
    sim.init();
    const Eigen::Vector3d n(0, -side, 0);  // towards the origin
    const Eigen::Vector3d s = x.cross(Eigen::Vector3d::UnitY());
    const Eigen::Vector3d viw = v - omega * s;
    const double fn = lj_magnitude(gap, 1.0) - 5.0 * n.dot(viw);
    const Eigen::Vector3d vs = viw - n.dot(viw) * n;
    const double fsm = std::min(2.0 * vs.norm(), 0.1 * std::abs(fn));
    const Eigen::Vector3d f = fn * n - fsm * vs.normalized();
    EXPECT_LT((sim.p.f[0] - f).norm(), 1e-12 * f.norm()) << "side " << side;
  }
}

namespace {
template <class Variant, std::size_t... I>
constexpr bool none_periodic(std::index_sequence<I...>) {
  return (!std::variant_alternative_t<I, Variant>::kPeriodic && ...);
}
}  // namespace

// Periodic ends are a boundary (boundary/periodic_axes.hpp): only a
// simulation type that has it wraps. An open box's minimum image and wrap do
// nothing, a periodic box's do, and an open box refuses a periodic axis
// rather than silently leaving it unwrapped.
TEST(PeriodicAxes, OnlyTheBoundaryMakesTheBoxWrap) {
  Domain<3, Wrap::periodic> periodic;
  Domain<3, Wrap::open> open;
  for (auto* lo : {&periodic.lo, &open.lo}) *lo = Eigen::Vector3d(-5, -10, -5);
  for (auto* hi : {&periodic.hi, &open.hi}) *hi = Eigen::Vector3d(5, 10, 5);
  periodic.periodic = {false, true, false};
  periodic.finalize();
  open.finalize();
  const Eigen::Vector3d dr(1.0, 15.0, -2.0), x(0.5, 12.0, 0.0);
  EXPECT_EQ(periodic.min_image(dr), Eigen::Vector3d(1.0, -5.0, -2.0));
  EXPECT_EQ(periodic.wrapped(x), Eigen::Vector3d(0.5, -8.0, 0.0));
  EXPECT_EQ(open.min_image(dr), dr);
  EXPECT_EQ(open.wrapped(x), x);
  open.periodic = {false, true, false};
  EXPECT_THROW(open.finalize(), std::logic_error);
  // The scenes' types: periodic drums wrap; capped drums and every box are open.
  static_assert(std::variant_alternative_t<0, DrumSim>::kPeriodic && DrumPeriodic::kPeriodic);
  static_assert(!DrumCapped::kPeriodic && !CapSim::kPeriodic && !OpenSim::kPeriodic);
  static_assert(FreeSim::kPeriodic && CylSim::kPeriodic);
  static_assert(none_periodic<BoxSim>(std::make_index_sequence<std::variant_size_v<BoxSim>>{}));
}
