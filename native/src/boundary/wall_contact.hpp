// The part every smooth wall shares (Rapaport 2002, Sec. III): given the
// vector r'_iw from the wall's contact point to particle i and the wall's
// velocity there, evaluate Eqs. (1), (2), (5) through the contact law and add
// the force and torque to the particle.
#pragma once
#include <cstddef>
#include <cstdint>

#include "contact/wall_batch.hpp"
#include "core/particles.hpp"

namespace granular {

// Which vector multiplies w_i in the wall's sliding velocity:
// paper = 1: w_i x r'_iw, as printed; pair = 1: Eq. (3) with the wall as a
// resting particle of diameter d_w, d_i/(d_i + d_w) w_i x r'_iw.
struct WallLever {
  double paper = 1.0, pair = 0.0;
  // The factor on r'_iw for a particle of diameter d_i.
  GRANULAR_HD double arm(double di, double d_wall) const { return paper + pair * di / (di + d_wall); }
};

template <class Law>
GRANULAR_INLINE void wall_contact(ParticleStore<3>& p, const Law& law, std::size_t i, const Eigen::Vector3d& rp,
                                  const Eigen::Vector3d& wall_velocity, double d_wall, const WallLever& lever) {
  const double di = p.d[i];
  const Eigen::Vector3d viw = p.v[i] - wall_velocity;
  const Eigen::Vector3d arm = lever.arm(di, d_wall) * rp;
  const auto res = law.wall_force(rp, di, 0.5 * (di + d_wall), viw, p.w[i], arm, p.species[i], p.inv_m[i]);
  p.f[i] += res.f;
  p.tq[i] += res.t;
}

// Evaluates the wall contacts gathered in batch b through the law's batch
// kernel and adds each to its particle, in the order gathered (each particle
// appears once per wall, so the sums are those of wall_contact).
template <int Dim, class Law>
void flush_wall_contacts(ParticleStore<Dim>& p, const Law& law, WallBatch<Dim>& b) {
  constexpr int kA = WallBatch<Dim>::kAng;
  law.wall_force_batch(b);
  for (int q = 0; q < b.n; ++q) {
    const std::uint32_t i = b.i[q];
    for (int a = 0; a < Dim; ++a) p.f[i][a] += b.f[a][q];
    for (int a = 0; a < kA; ++a) p.tq[i][a] += b.t[a][q];
  }
  b.n = 0;
}

}  // namespace granular
