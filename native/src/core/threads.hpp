// Explicit static partition of [0, n) over threads. Every parallel loop whose
// output order matters uses it, so results are bitwise identical for a given
// thread count.
#pragma once
#include <algorithm>
#include <cstddef>
#include <utility>

namespace granular {

inline std::pair<std::size_t, std::size_t> thread_block(std::size_t n, int nt, int t) {
  const std::size_t q = n / nt, r = n % nt;
  const std::size_t lo = t * q + std::min<std::size_t>(t, r);
  return {lo, lo + q + (static_cast<std::size_t>(t) < r ? 1 : 0)};
}

}  // namespace granular
