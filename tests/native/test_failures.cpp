// The run-time failure checks on hand-made states: a non-finite value, a
// speed with no source, an overlap beyond the limit; and a healthy state
// passing all of them.
#include <gtest/gtest.h>

#include "engine/health.hpp"
#include "helpers.hpp"

using namespace granular;
using namespace granular::test;

namespace {

FreeSim pair_at(double r) {
  FreeSim sim;
  open_box(sim, 10.0);
  add_sphere(sim, {-0.5 * r, 0, 0}, {0, 0, 0}, {0, 0, 0}, 1.0);
  add_sphere(sim, {0.5 * r, 0, 0}, {0, 0, 0}, {0, 0, 0}, 1.0);
  sim.law = Law3::from_paper(5, 10, 2, 10, 2, 0.5);
  sim.integrator.dt = 1e-3;
  sim.init();
  return sim;
}

std::string failure(const std::function<void()>& f) {
  try {
    f();
  } catch (const UnstableError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Failures, HealthyPairPasses) {
  omp_set_num_threads(1);
  FreeSim sim = pair_at(1.05);
  HealthLimits h;
  h.max_speed = 10.0;
  EXPECT_EQ(failure([&] { check_health(sim, h); }), "");
  EXPECT_EQ(failure([&] { sim.step(); }), "");
}

TEST(Failures, NonFiniteVelocityIsNamed) {
  omp_set_num_threads(1);
  FreeSim sim = pair_at(1.05);
  sim.p.v[1].x() = std::nan("");
  HealthLimits h;
  h.dt = 1e-3;
  h.contact_period = 0.1;
  const std::string m = failure([&] { check_health(sim, h); });
  EXPECT_NE(m.find("non-finite"), std::string::npos) << m;
  EXPECT_NE(m.find("particle id " + std::to_string(sim.p.id[1])), std::string::npos) << m;
  EXPECT_NE(m.find("1/100 of the shortest contact period"), std::string::npos) << m;
  // and the per-step check stops it too
  EXPECT_NE(failure([&] { sim.step(); }).find("non-finite"), std::string::npos);
}

TEST(Failures, OverlapBeyondTheLimitNamesBothParticles) {
  omp_set_num_threads(1);
  // contact distance 2^(1/6) d = 1.1225: r = 0.6 overlaps by 47 %
  FreeSim sim = pair_at(0.6);
  HealthLimits h;
  const std::string m = failure([&] { check_health(sim, h); });
  EXPECT_NE(m.find("particles id 0 and 1 overlap by 46.5"), std::string::npos) << m;
  FreeSim ok = pair_at(0.7);  // 37.6 %: below the 40 % limit
  EXPECT_EQ(failure([&] { check_health(ok, h); }), "");
}

TEST(Failures, SpeedWithoutASourceStopsTheStep) {
  omp_set_num_threads(1);
  FreeSim sim = pair_at(3.0);  // apart: free flight
  sim.max_speed = 5.0;
  sim.speed_sources = "test";
  sim.p.v[0].x() = 4.9;
  EXPECT_EQ(failure([&] { sim.step(); }), "");
  sim.p.v[0].x() = 5.1;
  const std::string m = failure([&] { sim.step(); });
  EXPECT_NE(m.find("energy is growing without a source"), std::string::npos) << m;
  EXPECT_NE(m.find("particle id 0 moves at 5.1"), std::string::npos) << m;
}
