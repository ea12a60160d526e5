// The half Verlet list equals the O(N^2) oracle, including pairs across
// periodic boundaries, in the drum geometry and in edge cases of the cell grid.
#include <gtest/gtest.h>

#include <random>

#include "helpers.hpp"

using namespace granular;
using namespace granular::test;

namespace {

void check_against_oracle(FreeSim& sim, double skin, int threads) {
  omp_set_num_threads(threads);
  sim.skin = skin;
  sim.init();
  auto range = [](double a, double b) { return Law3::range(a, b); };
  const auto oracle = brute_force_pairs(sim.p, sim.box, skin, range);
  const auto listed = sim.neighbors().pairs_by_id(sim.p);
  ASSERT_FALSE(oracle.empty());
  EXPECT_EQ(listed.size(), oracle.size());
  EXPECT_EQ(listed, oracle);
}

FreeSim random_cloud(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, std::array<bool, 3> periodic, int n,
                     unsigned seed, bool no_overlap = false) {
  FreeSim sim;
  sim.box.lo = lo;
  sim.box.hi = hi;
  sim.box.periodic = periodic;
  sim.box.finalize();
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d x;
    for (int k = 0; k < 3; ++k) x[k] = lo[k] + (hi[k] - lo[k]) * u(gen);
    const double d = 0.8 + 0.5 * u(gen);
    bool clash = false;
    for (std::size_t j = 0; no_overlap && j < sim.p.size() && !clash; ++j)
      clash = sim.box.min_image(x - sim.p.x[j]).norm() < Law3::range(d, sim.p.d[j]);
    if (clash) { --i; continue; }
    add_sphere(sim, x, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), d, i % 2);
  }
  return sim;
}

}  // namespace

TEST(Neighbors, DrumGeometryPeriodicAxis) {
  // Drum #A's box: x, z in [-10, 10], y periodic in [-64, 64); dense near the ends.
  auto sim = random_cloud({-10, -64, -10}, {10, 64, 10}, {false, true, false}, 6000, 1);
  // Put particles right at both periodic ends so that pairs straddle y = +-64.
  for (int i = 0; i < 200; ++i) sim.p.x[i].y() = (i % 2 ? 63.9 : -63.95) + 0.01 * (i % 5);
  int across = 0;
  for (int i = 0; i < 200; ++i)
    for (int j = i + 1; j < 200; ++j)
      if ((sim.p.x[i].y() > 0) != (sim.p.x[j].y() > 0) &&
          sim.box.min_image(sim.p.x[i] - sim.p.x[j]).norm() < Law3::range(sim.p.d[i], sim.p.d[j]))
        ++across;
  ASSERT_GT(across, 0);  // the test really has pairs across the boundary
  check_against_oracle(sim, 0.4, 1);
}

TEST(Neighbors, TwoThreadsSameList) {
  auto sim = random_cloud({-10, -64, -10}, {10, 64, 10}, {false, true, false}, 6000, 2);
  check_against_oracle(sim, 0.4, 2);
}

TEST(Neighbors, FullyPeriodicSmallBox) {
  // Three cells per axis: the smallest periodic grid the half stencil allows.
  auto sim = random_cloud({0, 0, 0}, {5.7, 5.7, 5.7}, {true, true, true}, 150, 3);
  check_against_oracle(sim, 0.4, 1);
}

TEST(Neighbors, PeriodicAxisTooShortForThreeCells) {
  // Fewer than three cells along a periodic axis collapses it to one cell.
  auto sim = random_cloud({0, 0, 0}, {20, 3.5, 20}, {false, true, false}, 400, 4);
  check_against_oracle(sim, 0.4, 1);
}

TEST(Neighbors, RebuiltAfterMotion) {
  // Particles drift; after many steps the list must still contain every pair in range.
  auto sim = random_cloud({-8, -16, -8}, {8, 16, 8}, {true, true, true}, 800, 5, true);
  sim.law = Law3::from_paper(5.0, 2, 2, 2, 2, 0.5);
  std::mt19937_64 gen(9);
  std::normal_distribution<double> g(0.0, 2.0);
  for (auto& v : sim.p.v) v = Eigen::Vector3d(g(gen), g(gen), g(gen));
  sim.skin = 0.3;
  sim.integrator.dt = 0.001;
  omp_set_num_threads(1);
  sim.init();
  for (int s = 0; s < 500; ++s) sim.step();
  EXPECT_GT(sim.neighbors().builds(), 2);
  // Every pair within the interaction range must be listed.
  auto range = [](double a, double b) { return Law3::range(a, b); };
  const auto in_range = brute_force_pairs(sim.p, sim.box, 0.0, range);
  const auto listed = sim.neighbors().pairs_by_id(sim.p);
  for (const auto& pr : in_range) EXPECT_TRUE(std::binary_search(listed.begin(), listed.end(), pr));
}
