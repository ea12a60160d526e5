// The drum's end caps at y = +-L/2: Rapaport (2002), Sec. III. Same friction as
// the curved wall. For particle i:
//   r_iw = (|r_i . y^| - L/2) y^, in range if r_iw . y^ > -2^(1/6) d_iw
//   r'_iw = +-r_iw, whichever points towards the origin;  s = r_i x y^
// The caps rotate with the drum (wall velocity Omega s).
#pragma once
#include <cstddef>

#include "boundary/wall_contact.hpp"

namespace granular {

struct EndCaps {
  double length = 128.0;  // L
  double omega = 0.5;
  double d_wall = 1.0;
  WallLever lever;  // see wall_contact.hpp
  // Cost per particle in listed pairs (for the threads' blocks,
  // neighbor/neighbor_list.hpp): two distance tests, most particles far.
  static constexpr unsigned kWeight = 1;

  // The time of the positions (the wall interface, engine/simulation.hpp) is not
  // needed: the caps turn in their own planes, so their surfaces never move.
  template <class Law>
  void apply(ParticleStore<3>& p, const Law& law, std::size_t lo, std::size_t hi, double /*t*/) const {
    const double half_l = 0.5 * length;
    for (std::size_t i = lo; i < hi; ++i) {
      const Eigen::Vector3d& x = p.x[i];
      const double di = p.d[i];
      const double gap = half_l - std::abs(x.y());
      if (gap >= Law::range(di, d_wall)) continue;
      const Eigen::Vector3d rp(0.0, x.y() > 0.0 ? -gap : gap, 0.0);  // r'_iw, towards the origin
      const Eigen::Vector3d s(-x.z(), 0.0, x.x());                    // r_i x y^
      wall_contact(p, law, i, rp, omega * s, d_wall, lever);
    }
  }
};

}  // namespace granular
