// A batch of particle-wall contacts in columns, for the laws whose wall
// contacts run in SIMD lanes (Law::kVectorised), as contact/pair_batch.hpp
// does for pairs. A smooth wall (boundary/) fills a batch with the geometry
// of its contacts, wall_force_batch runs the law's wall_lane
// (contact/lane.hpp) over them column by column, and the wall adds the
// results to the particles (boundary/wall_contact.hpp). The lane function is
// the one the one-at-a-time path calls, so both give the same bits
// (tests/native/test_batch_kernels.cpp).
#pragma once
#include <cstdint>
#include <type_traits>

#include "contact/lane.hpp"

namespace granular {

template <int Dim>
struct WallBatch {
  static constexpr int kSize = 64;
  static constexpr int kAng = kAngDim<Dim>;
  int n = 0;
  // Inputs, as WallContact holds them: rp = r'_iw (wall contact point to
  // particle), v = v_i - the wall's velocity there, lever = the vector that
  // multiplies w_i in the sliding velocity (boundary/wall_contact.hpp),
  // d_iw = (d_i + d_w)/2.
  alignas(64) std::uint32_t i[kSize];
  alignas(64) std::int32_t ci[kSize];
  alignas(64) double rp[Dim][kSize];
  alignas(64) double v[Dim][kSize];
  alignas(64) double w[kAng][kSize];
  alignas(64) double lever[Dim][kSize];
  alignas(64) double di[kSize];
  alignas(64) double d_iw[kSize];
  alignas(64) double inv_mi[kSize];
  // Outputs: force and torque on the particle.
  alignas(64) double f[Dim][kSize];
  alignas(64) double t[kAng][kSize];
};

// Whether the walls run Law's contacts in SIMD batches (else one at a time;
// each particle meets a wall once, so both give the same sums).
template <class Law, int Dim>
struct HasWallBatch : std::bool_constant<Law::kVectorised> {};

// The law's wall_lane over every contact of batch b, in SIMD lanes.
template <class Law, int Dim>
void wall_force_batch(const Law& law, WallBatch<Dim>& b) {
  constexpr int kA = kAngDim<Dim>;
  const int nb = b.n;
#pragma omp simd
  for (int k = 0; k < nb; ++k) {
    WallContact<Dim> c;
    for (int a = 0; a < Dim; ++a) {
      c.rp[a] = b.rp[a][k];
      c.v[a] = b.v[a][k];
      c.lever[a] = b.lever[a][k];
    }
    for (int a = 0; a < kA; ++a) c.w[a] = b.w[a][k];
    c.di = b.di[k];
    c.d_iw = b.d_iw[k];
    c.ci = b.ci[k];
    c.inv_mi = b.inv_mi[k];
    WallForce<Dim> o;
    law.wall_lane(c, o);
    for (int a = 0; a < Dim; ++a) b.f[a][k] = o.f[a];
    for (int a = 0; a < kA; ++a) b.t[a][k] = o.t[a];
  }
}

}  // namespace granular
