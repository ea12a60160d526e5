// Infinite plane walls (the particles scene, docs/particles_scene.md): smooth,
// resting walls of Rapaport's (2002) Sec. III kind. Plane k passes through the
// point p_k with unit normal n_k on the particles' side. For particle i at
// height h = (r_i - p_k) . n_k above it:
//   r'_iw = h n_k                (the foot of the perpendicular -> particle)
//   in range if h < 2^(1/6) d_iw (Law::range(d_i, d_w)), d_iw = (d_i + d_w)/2
//   wall velocity 0,  v^s_iw = v_i - (r^ . v_i) r^ - w_i x r'_iw   then Eq. (5)
// through boundary/wall_contact.hpp (Eqs. (1), (2), (5)), with the drum's
// reading of the spin term (lever, see wall_contact.hpp). A particle whose
// centre is behind a plane (h <= 0) has passed through it: the plane does not
// push it, and the run stops (behind() below; engine/particles.cpp).
#pragma once
#include <cstddef>
#include <vector>

#include "boundary/wall_contact.hpp"

namespace granular {

struct PlaneWalls {
  struct Plane {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit length, towards the particles
  };
  std::vector<Plane> planes;
  double d_wall = 1.0;  // d_w
  WallLever lever;      // reading of the spin term, see wall_contact.hpp
  // Cost per particle in listed pairs (for the threads' blocks,
  // neighbor/neighbor_list.hpp): one distance test per plane, few contacts.
  static constexpr unsigned kWeight = 1;

  // The walls rest, so the time of the positions (the wall interface,
  // engine/simulation.hpp) is not needed.
  template <class Law>
  void apply(ParticleStore<3>& p, const Law& law, std::size_t lo, std::size_t hi, double /*t*/) const {
    for (std::size_t i = lo; i < hi; ++i) {
      const double reach = Law::range(p.d[i], d_wall);
      for (const Plane& w : planes) {
        const double h = (p.x[i] - w.point).dot(w.normal);
        if (h <= 0.0 || h >= reach) continue;
        wall_contact(p, law, i, h * w.normal, Eigen::Vector3d::Zero(), d_wall, lever);  // r'_iw = h n
      }
    }
  }

  // The first particle (in store order) whose centre is behind a plane, for
  // the run's containment check: its index and the plane's, or
  // {p.size(), 0} when every particle is on the particles' side.
  struct Behind {
    std::size_t particle, plane;
    double height;
  };
  Behind behind(const ParticleStore<3>& p) const {
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t k = 0; k < planes.size(); ++k) {
        const double h = (p.x[i] - planes[k].point).dot(planes[k].normal);
        if (!(h > 0.0)) return {i, k, h};
      }
    return {p.size(), 0, 0.0};
  }
};

}  // namespace granular
