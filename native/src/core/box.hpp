// The simulation box. Periodic axes are a property of the box and minimum image
// is applied here and nowhere else.
#pragma once
#include <array>
#include <cmath>

#include "core/space.hpp"

namespace granular {

template <int Dim>
struct Box {
  using V = Vec<Dim>;
  V lo = V::Zero();
  V hi = V::Zero();
  std::array<bool, Dim> periodic{};

  V length() const { return hi - lo; }

  // Branch-free minimum image: inv_len_ is 0 on non-periodic axes.
  V min_image(V dr) const {
    for (int k = 0; k < Dim; ++k) dr[k] -= len_[k] * std::nearbyint(dr[k] * inv_len_[k]);
    return dr;
  }

  // Back into [lo, hi) along periodic axes. Branch-free and whole-vector (the
  // factor is floor(0) = 0 on the others), so that the caller's copy stays in
  // registers rather than being written one component at a time.
  V wrapped(const V& x) const {
    const V cells = ((x - lo).cwiseProduct(inv_len_)).array().floor().matrix();
    return x - len_.cwiseProduct(cells);
  }
  void wrap(V& x) const { x = wrapped(x); }

  // Call after setting lo, hi, periodic.
  void finalize() {
    len_ = hi - lo;
    for (int k = 0; k < Dim; ++k) inv_len_[k] = periodic[k] ? 1.0 / len_[k] : 0.0;
  }

 private:
  V len_ = V::Zero();
  V inv_len_ = V::Zero();
};

}  // namespace granular
