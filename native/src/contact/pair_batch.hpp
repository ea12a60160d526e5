// A batch of pair contacts in columns (structure of arrays), for contact laws
// that evaluate many contacts in one vectorised loop (`pair_force_batch`).
// The pair loop (engine/simulation.hpp) gathers the contacts in range into a
// batch, the law computes their forces and torques column by column, and the
// loop adds them to the particles: the square roots and divisions of a
// contact then run side by side in SIMD lanes instead of as one dependent
// chain per contact. A law's batch kernel computes exactly what its
// pair_force computes (tests/native/test_batch_kernels.cpp).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/space.hpp"

namespace granular {

template <int Dim>
struct PairBatch {
  static constexpr int kSize = 64;
  static constexpr int kAng = Space<Dim>::kAngDim;
  int n = 0;
  // Inputs, as pair_force takes them: dr = r_i - r_j (minimum image),
  // r2 = |dr|^2, v = v_i - v_j.
  alignas(64) std::uint32_t i[kSize];
  alignas(64) std::uint32_t j[kSize];
  alignas(64) std::int32_t ci[kSize];
  alignas(64) std::int32_t cj[kSize];
  alignas(64) double dr[Dim][kSize];
  alignas(64) double r2[kSize];
  alignas(64) double di[kSize];
  alignas(64) double dj[kSize];
  alignas(64) double v[Dim][kSize];
  alignas(64) double wi[kAng][kSize];
  alignas(64) double wj[kAng][kSize];
  alignas(64) double inv_mi[kSize];
  alignas(64) double inv_mj[kSize];
  // Outputs: force on i (j gets -f), torques on i and j.
  alignas(64) double f[Dim][kSize];
  alignas(64) double ti[kAng][kSize];
  alignas(64) double tj[kAng][kSize];
};

// Whether Law has a batch kernel for dimension Dim.
template <class Law, int Dim, class = void>
struct HasPairBatch : std::false_type {};
template <class Law, int Dim>
struct HasPairBatch<Law, Dim,
                    std::void_t<decltype(std::declval<const Law&>().pair_force_batch(std::declval<PairBatch<Dim>&>()))>>
    : std::true_type {};

// Component forms of space.hpp's spin_cross (omega x r) and moment (r x f),
// for the batch kernels' scalar lanes.
GRANULAR_INLINE void spin_cross_c(const double (&w)[3], const double (&r)[3], double (&out)[3]) {
  out[0] = w[1] * r[2] - w[2] * r[1];
  out[1] = w[2] * r[0] - w[0] * r[2];
  out[2] = w[0] * r[1] - w[1] * r[0];
}
GRANULAR_INLINE void spin_cross_c(const double (&w)[1], const double (&r)[2], double (&out)[2]) {
  out[0] = -w[0] * r[1];
  out[1] = w[0] * r[0];
}
GRANULAR_INLINE void moment_c(const double (&r)[3], const double (&f)[3], double (&out)[3]) {
  out[0] = r[1] * f[2] - r[2] * f[1];
  out[1] = r[2] * f[0] - r[0] * f[2];
  out[2] = r[0] * f[1] - r[1] * f[0];
}
GRANULAR_INLINE void moment_c(const double (&r)[2], const double (&f)[2], double (&out)[1]) {
  out[0] = r[0] * f[1] - r[1] * f[0];
}

// The capped viscous friction of the laws' kernels (pairs and walls), in one
// lane: f = -min(g |v|, mu |f_n|) v/|v|, zero at v = 0 (v2 = |v|^2,
// mu_fn = mu |f_n|). -min(...) / |v|, and +0 at v = 0 (then the min is 0,
// so 0 / 1), written without a select around the division: a division under
// a condition keeps the loop scalar without AVX-512's masked lanes (GCC 12,
// AVX2: "control flow in loop").
template <int N>
GRANULAR_INLINE void capped_friction_c(const double (&v)[N], double v2, double g, double mu_fn, double (&f)[N]) {
  const double vabs = std::sqrt(v2);
  const double mag = std::min(g * vabs, mu_fn);
  const double scale = (0.0 - mag) / (vabs + static_cast<double>(v2 == 0.0));
  for (int a = 0; a < N; ++a) f[a] = scale * v[a];
}

}  // namespace granular
