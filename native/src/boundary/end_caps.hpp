// The drum's end caps at y = +-L/2: Rapaport (2002), Sec. III. Same friction as
// the curved wall. For particle i:
//   r_iw = (|r_i . y^| - L/2) y^, in range if r_iw . y^ > -2^(1/6) d_iw
//   r'_iw = +-r_iw, whichever points towards the origin;  s = r_i x y^
// The caps rotate with the drum (wall velocity Omega s).
#pragma once
#include <cmath>
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

  // Whether a particle at height y of diameter d_i is within the law's reach
  // of a cap: its gap L/2 - |y| to the nearer cap is below range(d_i, d_w).
  // Host and device (GRANULAR_HD): the GPU drum (gpu/drum_kernels.hpp) tests
  // the same way.
  template <class Law>
  GRANULAR_HD bool in_reach(double y, double di) const {
    const double gap = 0.5 * length - std::abs(y);
    return !(gap >= Law::range(di, d_wall));
  }

  // The contact's geometry from the header's equations, for a particle at
  // (x, y, z) of diameter d_i moving at (vx, vy, vz): r'_iw into rp, v_i -
  // Omega r_i x y^ into v, the lever multiplying w_i into lv, and d_iw. Host
  // and device: apply() and the GPU drum compute the same numbers.
  GRANULAR_HD void geometry(double x, double y, double z, double di, double vx, double vy, double vz,
                            double (&rp)[3], double (&v)[3], double (&lv)[3], double& d_iw) const {
    const double gap = 0.5 * length - std::abs(y);
    rp[0] = 0.0;  // r'_iw, towards the origin
    rp[1] = y > 0.0 ? -gap : gap;
    rp[2] = 0.0;
    v[0] = vx - omega * (-z);  // v_i - Omega r_i x y^
    v[1] = vy - omega * 0.0;
    v[2] = vz - omega * x;
    const double arm = lever.arm(di, d_wall);
    for (int a = 0; a < 3; ++a) lv[a] = arm * rp[a];
    d_iw = 0.5 * (di + d_wall);
  }

  // The time of the positions (the wall interface, engine/simulation.hpp) is not
  // needed: the caps turn in their own planes, so their surfaces never move.
  template <class Law>
  void apply(ParticleStore<3>& p, const Law& law, std::size_t lo, std::size_t hi, double /*t*/) const {
    for (std::size_t i = lo; i < hi; ++i) {
      const Eigen::Vector3d& x = p.x[i];
      const double di = p.d[i];
      if (!in_reach<Law>(x.y(), di)) continue;
      const Eigen::Vector3d& vi = p.v[i];
      double rp[3], v[3], lv[3], d_iw;
      geometry(x.x(), x.y(), x.z(), di, vi.x(), vi.y(), vi.z(), rp, v, lv, d_iw);
      const Eigen::Vector3d r(rp[0], rp[1], rp[2]), viw(v[0], v[1], v[2]), arm(lv[0], lv[1], lv[2]);
      const auto res = law.wall_force(r, di, d_iw, viw, p.w[i], arm, p.species[i], p.inv_m[i]);
      p.f[i] += res.f;
      p.tq[i] += res.t;
    }
  }
};

}  // namespace granular
