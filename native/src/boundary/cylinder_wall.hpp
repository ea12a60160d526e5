// The drum's curved wall: Rapaport (2002), Sec. III. Axis along y through the
// origin, diameter D, smooth wall of "diameter" d_w = 1 rotating with angular
// velocity Omega. For particle i:
//   r_iw  = r_i - (r_i . y^) y^,  in range if r_iw > D/2 - 2^(1/6) d_iw, d_iw = (d_i + d_w)/2
//   r'_iw = (1 - D / 2 r_iw) r_iw                    (wall contact point -> particle)
//   s     = (D/2) r^_iw x y^,  v_iw = v_i - Omega s
//   v^s_iw = v_iw - (r^ . v_iw) r^ - w_i x r'_iw       then Eq. (5)
// lever reading: "paper" uses w_i x r'_iw as printed; "pair" uses Eq. (3) with the
// wall as a resting particle of diameter d_w, i.e. d_i/(d_i + d_w) w_i x r'_iw.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "boundary/wall_contact.hpp"

namespace granular {

struct CylinderWall {
  double diameter = 16.0;  // D
  double omega = 0.5;      // Omega
  double d_wall = 1.0;     // d_w
  WallLever lever;         // reading of the spin term, see wall_contact.hpp
  // Cost per particle in listed pairs (for the threads' blocks,
  // neighbor/neighbor_list.hpp): 17 ns in drum #A.
  static constexpr unsigned kWeight = 8;

  // The time of the positions (the wall interface, engine/simulation.hpp) is not
  // needed: the wall turns about its own axis, so its surface never moves.
  // In two passes over blocks of particles: first the ones within reach of
  // the wall, without a branch (a fifth of the particles touch the wall, in
  // no pattern a branch predictor could follow), then their contacts.
  template <class Law>
  void apply(ParticleStore<3>& p, const Law& law, std::size_t lo, std::size_t hi, double /*t*/) const {
    const double half_d = 0.5 * diameter;
    constexpr std::size_t kBlock = 256;
    std::uint32_t near[kBlock];
    for (std::size_t b0 = lo; b0 < hi; b0 += kBlock) {
      const std::size_t b1 = std::min(hi, b0 + kBlock);
      std::size_t m = 0;
      for (std::size_t i = b0; i < b1; ++i) {
        const Eigen::Vector3d& x = p.x[i];
        const double rr = x.x() * x.x() + x.z() * x.z();
        const double reach = half_d - Law::range(p.d[i], d_wall);
        near[m] = static_cast<std::uint32_t>(i);
        m += rr > reach * reach;
      }
      for (std::size_t k = 0; k < m; ++k) {
        const std::size_t i = near[k];
        const Eigen::Vector3d& x = p.x[i];
        const double r = std::sqrt(x.x() * x.x() + x.z() * x.z());
        const Eigen::Vector3d riw(x.x(), 0.0, x.z());
        const Eigen::Vector3d rp = (1.0 - half_d / r) * riw;                      // r'_iw
        const Eigen::Vector3d s(-half_d * x.z() / r, 0.0, half_d * x.x() / r);   // (D/2) r^_iw x y^
        wall_contact(p, law, i, rp, omega * s, d_wall, lever);
      }
    }
  }
};

}  // namespace granular
