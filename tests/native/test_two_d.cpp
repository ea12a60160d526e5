// The engine is templated on the dimension: the same particle store, neighbour
// list, contact law and integrator run in 2D (the shaken box will). A head-on
// collision is the same one-dimensional problem in 2D and 3D, so it must give
// the same restitution; the 2D neighbour list must match the oracle.
#include <gtest/gtest.h>

#include <random>

#include "contact/rapaport.hpp"
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"

using namespace granular;

namespace {

using Sim2 = Simulation<2, RapaportLaw<2>, Leapfrog<2>, PeriodicAxes>;
using Sim3 = Simulation<3, RapaportLaw<3>, Leapfrog<3>, PeriodicAxes>;

template <class Sim>
double restitution(double dt) {
  Sim sim;
  using V = Vec<Sim::kDim>;
  using A = Ang<Sim::kDim>;
  sim.domain.lo = V::Constant(-10);
  sim.domain.hi = V::Constant(10);
  sim.domain.finalize();
  sim.law = RapaportLaw<Sim::kDim>::from_paper(5.0, 10, 2, 10, 2, 0.5);
  sim.integrator.dt = dt;
  V x = V::Zero(), v = V::Zero();
  x[0] = -0.57;
  v[0] = 0.5;
  sim.p.add(x, v, A::Zero(), 1.0, 1.0, 0.1, 0);
  sim.p.add(-x, -v, A::Zero(), 1.0, 1.0, 0.1, 0);
  sim.init();
  for (int k = 0; k < 20000; ++k) sim.step();
  const auto a = sim.p.id[0] == 0 ? 0 : 1;
  return (sim.p.v[1 - a][0] - sim.p.v[a][0]) / 1.0;
}

// A 40 x 30 strip, periodic along x.
Sim2 periodic_strip() {
  Sim2 sim;
  sim.domain.lo = Eigen::Vector2d(0, 0);
  sim.domain.hi = Eigen::Vector2d(40, 30);
  sim.domain.periodic = {true, false};
  sim.domain.finalize();
  return sim;
}

// n disks at uniform random places in the strip, diameters uniform in
// [d0, d0 + spread); species alternate 0, 1 if `alternate`, else all 0.
void add_random_disks(Sim2& sim, int n, unsigned seed, double d0, double spread, bool alternate) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < n; ++i)
    sim.p.add(Eigen::Vector2d(40 * u(gen), 30 * u(gen)), Eigen::Vector2d::Zero(), Ang<2>::Zero(), d0 + spread * u(gen),
              1.0, 0.1, alternate ? i % 2 : 0);
}

}  // namespace

TEST(TwoD, HeadOnCollisionSameAsIn3D) {
  omp_set_num_threads(1);
  const double e2 = restitution<Sim2>(1e-4), e3 = restitution<Sim3>(1e-4);
  EXPECT_GT(e2, 0.1);
  EXPECT_EQ(e2, e3);  // identical arithmetic along x
}

TEST(TwoD, NeighborListMatchesOracle) {
  omp_set_num_threads(2);
  Sim2 sim = periodic_strip();
  add_random_disks(sim, 900, 11, 0.8, 0.5, true);
  sim.skin = 0.3;
  sim.init();
  auto range = [](double a, double b) { return RapaportLaw<2>::range(a, b); };
  const auto oracle = brute_force_pairs(sim.p, sim.domain, 0.3, range);
  ASSERT_GT(oracle.size(), 100u);
  EXPECT_EQ(sim.neighbors().pairs_by_id(sim.p), oracle);
}

// The shaken box's big disk among its grains: a class of its own (the cells
// are sized for the grains), here against the walls, the corner and the
// periodic end, on one thread and two.
TEST(TwoD, BigDiskListedAgainstItsGrains) {
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    for (const Eigen::Vector2d& at : {Eigen::Vector2d(20, 15), Eigen::Vector2d(1, 1), Eigen::Vector2d(39.5, 28.5)}) {
      Sim2 sim = periodic_strip();
      sim.p.add(at, Eigen::Vector2d::Zero(), Ang<2>::Zero(), 8.0, 16.0, 10.0, 1);
      add_random_disks(sim, 700, 17, 1.7, 0.6, false);
      sim.skin = 0.5;
      sim.init();
      EXPECT_EQ(sim.neighbors().n_large(), 1u);
      auto range = [](double a, double b) { return RapaportLaw<2>::range(a, b); };
      const auto oracle = brute_force_pairs(sim.p, sim.domain, 0.5, range);
      std::size_t big = 0;
      for (const auto& pr : oracle) big += pr.first == 0;
      ASSERT_GT(big, 10u);  // the big disk has many partners to find
      EXPECT_EQ(sim.neighbors().pairs_by_id(sim.p), oracle);
    }
  }
}
