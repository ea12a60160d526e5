// A batch of particle-wall contacts in columns, for contact laws that
// evaluate many wall contacts in one vectorised loop (`wall_force_batch`),
// as contact/pair_batch.hpp does for pairs. A smooth wall (boundary/) fills
// a batch with the geometry of its contacts, the law computes their forces
// and torques column by column, and the wall adds them to the particles
// (boundary/wall_contact.hpp). A law's batch kernel computes exactly what its
// wall_force computes (tests/native/test_batch_kernels.cpp).
#pragma once
#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/space.hpp"

namespace granular {

template <int Dim>
struct WallBatch {
  static constexpr int kSize = 64;
  static constexpr int kAng = Space<Dim>::kAngDim;
  int n = 0;
  // Inputs, as wall_force takes them: rp = r'_iw (wall contact point to
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

// Whether Law has a wall batch kernel for dimension Dim.
template <class Law, int Dim, class = void>
struct HasWallBatch : std::false_type {};
template <class Law, int Dim>
struct HasWallBatch<Law, Dim,
                    std::void_t<decltype(std::declval<const Law&>().wall_force_batch(std::declval<WallBatch<Dim>&>()))>>
    : std::true_type {};

}  // namespace granular
