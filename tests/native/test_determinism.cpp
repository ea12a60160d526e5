// Results are bitwise identical for a given thread count and seed.
#include <gtest/gtest.h>

#include "engine/drum.hpp"
#include "helpers.hpp"

using namespace granular;

namespace {

std::vector<double> run_small_drum(int threads, std::uint64_t seed) {
  omp_set_num_threads(threads);
  DrumScene s;
  s.name = "det";
  s.length = 32;
  s.diameter = 10;
  s.seed = seed;
  DrumSim sim = make_drum(s);
  std::vector<double> out;
  std::visit(
      [&](auto& v) {
        for (int k = 0; k < 600; ++k) v.step();
        std::vector<std::size_t> order(v.p.size());
        for (std::size_t i = 0; i < v.p.size(); ++i) order[v.p.id[i]] = i;
        for (auto i : order)
          for (int c = 0; c < 3; ++c) {
            out.push_back(v.p.x[i][c]);
            out.push_back(v.p.w[i][c]);
          }
      },
      sim);
  return out;
}

}  // namespace

TEST(Determinism, SameThreadsSameSeedBitwiseEqual) {
  for (int t : {1, 2}) {
    const auto a = run_small_drum(t, 3), b = run_small_drum(t, 3);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double))) << t << " thread(s)";
  }
}

TEST(Determinism, SeedMatters) {
  const auto a = run_small_drum(1, 3), b = run_small_drum(1, 4);
  EXPECT_NE(0, std::memcmp(a.data(), b.data(), std::min(a.size(), b.size()) * sizeof(double)));
}
