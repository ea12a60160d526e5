// Explicit static partition of [0, n) over threads. Every parallel loop whose
// output order matters uses it, so results are bitwise identical for a given
// thread count.
#pragma once
#include <cstddef>
#include <utility>

#include "core/column.hpp"

namespace granular {

inline std::pair<std::size_t, std::size_t> thread_block(std::size_t n, int nt, int t) {
  // Each bound but n a multiple of kLineParticles, so that no cache line of a
  // column (core/column.hpp) holds two blocks' particles.
  const auto bound = [&](int k) {
    return k == nt ? n : n * static_cast<std::size_t>(k) / static_cast<std::size_t>(nt) / kLineParticles * kLineParticles;
  };
  return {bound(t), bound(t + 1)};
}

}  // namespace granular
