// The pair loop against a bare kernel, for `granular bench` (the breakdown
// in engine/timers.hpp): the contact law alone, on one thread, over a fixed
// list of the pairs in contact now (no list walk, no range test, no
// buffers).
#pragma once
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace granular {

// Over the contacts of simulation `sim` (engine/simulation.hpp) at its
// current state: returns their number and the nanoseconds per contact (best
// of `passes` passes).
template <class Sim>
std::pair<std::size_t, double> bare_kernel(const Sim& sim, int passes = 20) {
  using Law = std::decay_t<decltype(sim.law)>;
  using V = typename Sim::V;
  using A = typename Sim::A;
  using Clock = std::chrono::steady_clock;
  const auto& nl = sim.neighbors();
  const auto& p = sim.p;
  const auto& domain = sim.domain;
  const Law& law = sim.law;
  std::vector<std::uint32_t> ci, cj;
  for (int t = 0; t < nl.threads(); ++t) {
    const auto [lo, hi] = nl.row_block(t);
    for (std::size_t i = lo; i < hi; ++i)
      for (std::uint32_t k = nl.begin(i); k < nl.end(i); ++k) {
        const std::uint32_t j = nl.col(t)[k];
        const double rc = Law::range(p.d[i], p.d[j]);
        if (domain.min_image(p.x[i] - p.x[j]).squaredNorm() < rc * rc) {
          ci.push_back(static_cast<std::uint32_t>(i));
          cj.push_back(j);
        }
      }
  }
  if (ci.empty()) return {0, 0.0};
  std::vector<V> F(p.size(), V::Zero());
  std::vector<A> T(p.size(), A::Zero());
  double best = std::numeric_limits<double>::infinity();
  for (int pass = 0; pass < passes; ++pass) {
    const auto t0 = Clock::now();
    for (std::size_t c = 0; c < ci.size(); ++c) {
      const std::uint32_t i = ci[c], j = cj[c];
      const V dr = domain.min_image(p.x[i] - p.x[j]);
      const auto r = law.pair_force(dr, dr.squaredNorm(), p.d[i], p.d[j], p.v[i] - p.v[j], p.w[i], p.w[j], p.species[i],
                                    p.species[j], p.inv_m[i], p.inv_m[j]);
      F[i] += r.f;
      F[j] -= r.f;
      T[i] += r.ti;
      T[j] += r.tj;
    }
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  volatile double sink = F[0][0] + T[0][0];  // keep the loop
  (void)sink;
  return {ci.size(), 1e9 * best / static_cast<double>(ci.size())};
}

}  // namespace granular
