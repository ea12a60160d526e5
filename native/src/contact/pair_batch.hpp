// A batch of pair contacts in columns (structure of arrays), for the laws the
// pair loop runs in SIMD lanes (Law::kVectorised). The pair loop
// (engine/simulation.hpp) gathers the contacts in range into a batch,
// pair_force_batch runs the law's pair_lane (contact/lane.hpp) over them column
// by column, and the loop adds the results to the particles: the square roots
// and divisions of a contact then run side by side in SIMD lanes instead of
// as one dependent chain per contact. The lane function is the one the
// one-at-a-time path calls, so both give the same bits
// (tests/native/test_batch_kernels.cpp).
#pragma once
#include <cstdint>
#include <type_traits>

#include "contact/lane.hpp"

namespace granular {

template <int Dim>
struct PairBatch {
  static constexpr int kSize = 64;
  static constexpr int kAng = kAngDim<Dim>;
  int n = 0;
  // Inputs, as PairContact holds them: dr = r_i - r_j (minimum image),
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

// Whether the pair loop runs Law in SIMD batches (else one contact at a time;
// the two sum a particle's contacts in different orders).
template <class Law, int Dim>
struct HasPairBatch : std::bool_constant<Law::kVectorised> {};

// The law's pair_lane over every contact of batch b, in SIMD lanes.
template <class Law, int Dim>
void pair_force_batch(const Law& law, PairBatch<Dim>& b) {
  constexpr int kA = kAngDim<Dim>;
  const int nb = b.n;
#pragma omp simd
  for (int k = 0; k < nb; ++k) {
    PairContact<Dim> c;
    for (int a = 0; a < Dim; ++a) {
      c.dr[a] = b.dr[a][k];
      c.v[a] = b.v[a][k];
    }
    for (int a = 0; a < kA; ++a) {
      c.wi[a] = b.wi[a][k];
      c.wj[a] = b.wj[a][k];
    }
    c.r2 = b.r2[k];
    c.di = b.di[k];
    c.dj = b.dj[k];
    c.ci = b.ci[k];
    c.cj = b.cj[k];
    c.inv_mi = b.inv_mi[k];
    c.inv_mj = b.inv_mj[k];
    PairForce<Dim> o;
    law.pair_lane(c, o);
    for (int a = 0; a < Dim; ++a) b.f[a][k] = o.f[a];
    for (int a = 0; a < kA; ++a) {
      b.ti[a][k] = o.ti[a];
      b.tj[a][k] = o.tj[a];
    }
  }
}

}  // namespace granular
