// A per-particle column that starts on a cache line.
//
// Thread t owns the particles of its block and writes their columns every
// step; a block's first and last particles would share a line with the
// neighbouring block's wherever a column starts off a line, and that line
// would cross between the cores at each write. With every column on a line
// and every block boundary a multiple of kLineParticles
// (neighbor/neighbor_list.hpp, balance), no line of a column holds two
// threads' particles. The same holds for the buffers one thread writes and
// another reads (the ghost and tail-task buffers, engine/parallel/ghost_forces.hpp):
// each starts on a line of its own, so two never share one.
#pragma once
#include <cstddef>
#include <new>
#include <vector>

namespace granular {

inline constexpr std::size_t kCacheLine = 64;
// Particles per cache-line-aligned run in every column: 8 doubles are one line, 8 two- or
// three-vectors two or three.
inline constexpr std::size_t kLineParticles = 8;

template <class T>
struct LineAligned {
  using value_type = T;
  LineAligned() = default;
  template <class U>
  LineAligned(const LineAligned<U>&) noexcept {}
  T* allocate(std::size_t n) {
    return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(kCacheLine)));
  }
  void deallocate(T* q, std::size_t) noexcept { ::operator delete(q, std::align_val_t(kCacheLine)); }
  template <class U>
  bool operator==(const LineAligned<U>&) const noexcept {
    return true;
  }
  template <class U>
  bool operator!=(const LineAligned<U>&) const noexcept {
    return false;
  }
};

template <class T>
using Column = std::vector<T, LineAligned<T>>;

}  // namespace granular
