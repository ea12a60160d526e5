// The shaken box's floor and side walls as flat surfaces moving rigidly with
// the shaker (box.walls = "smooth"): the smooth counterpart of Poeschel and
// Herrmann's (1995) walls of particles, to measure what the particles'
// roughness and their neighbour-list entries cost and change.
//
// A grain i touches a wall as it would touch a wall particle j of radius r_w
// (box.wall_radius) sitting on the wall's centre line r_w behind the surface,
// at the foot of the perpendicular from i:
//   floor:      r_j = (x_i, y_box(t) - r_w)                     surface y = y_box(t)
//   left wall:  r_j = (-W/2 - r_w, min(y_i, y_box(t) + y_top))  surface x = -W/2
//   right wall: r_j = (+W/2 + r_w, min(y_i, y_box(t) + y_top))  surface x = +W/2
// with v_j = (0, dy_box/dt) (integrate/motion.hpp), w_j = 0, 1/m_j the wall
// particle's inverse mass (0 for box.wall_mass = "infinite") and species
// kWallSpecies, through the scene's own pair law (Eqs. (1)-(6) of
// contact/poeschel_herrmann.hpp, or contact/viscel.hpp): the force of a wall
// particle straight beneath or beside the grain, on a perfectly flat wall.
// The surfaces coincide with the particle walls' (box_particles in
// scene/box_scene.cpp: floor centres at y = -r_w, side centres at x = +-(W/2 + r_w)),
// and y_top is the centre of the particle walls' top particle, so a side wall
// ends in the same half disk at the same height.
// A flat wall is a half plane: only a grain on the box's side of the centre
// line is pushed (one whose centre passed it has escaped, and the run's
// containment check, engine/box.cpp, says so).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "contact/lane.hpp"  // GRANULAR_HD
#include "core/particles.hpp"
#include "integrate/motion.hpp"

namespace granular {

// The grain at (x, y) seen from each wall's virtual particle, for the walls
// on whose side of the centre line it is: touch(dx, dy) with (dx, dy) = r_i -
// r_j, for the floor, the left wall, the right wall in turn. floor_c =
// y_box(t) - r_w, top_c = y_box(t) + y_top, xc = W/2 + r_w. Host and device
// (GRANULAR_HD): FlatBoxWalls::apply and the GPU box (gpu/box_kernels.hpp)
// call it.
template <class Touch>
GRANULAR_HD void flat_box_offsets(double x, double y, double floor_c, double top_c, double xc, Touch&& touch) {
  if (y > floor_c) touch(0.0, y - floor_c);
  const double dy = y - std::min(y, top_c);
  if (x > -xc) touch(x + xc, dy);
  if (x < xc) touch(x - xc, dy);
}

struct FlatBoxWalls {
  using V = Vec<2>;
  using A = Ang<2>;

  double half_width = 30.0;    // W/2: the side walls' surfaces at x = +-W/2
  double wall_radius = 1.0;    // r_w of the virtual wall particle
  double wall_inv_mass = 0.0;  // 1/m_w; 0: infinitely heavy
  double side_top = 150.0;     // y_top: the side walls' top centre above the floor surface, at rest
  ShakerMotion<2> shaker;      // y_box(t); its anchors are unused (no wall particles)
  // Cost per particle in listed pairs (for the threads' blocks,
  // neighbor/neighbor_list.hpp): three distance tests, a contact for few.
  static constexpr unsigned kWeight = 2;

  // t: the time of the positions (engine/simulation.hpp).
  template <class Law>
  void apply(ParticleStore<2>& p, const Law& law, std::size_t lo, std::size_t hi, double t) const {
    const double yb = shaker.y(t);
    const V vw(0.0, shaker.vy(t));
    const double floor_c = yb - wall_radius, top_c = yb + side_top, xc = half_width + wall_radius;
    // Scalars until a contact is found: building a vector per test costs
    // more than the tests (a store-forwarding stall per temporary).
    for (std::size_t i = lo; i < hi; ++i) {
      const double rc = Law::range(p.d[i], 2.0 * wall_radius);
      flat_box_offsets(p.x[i].x(), p.x[i].y(), floor_c, top_c, xc,
                       [&](double dx, double dy) { touch(p, law, i, dx, dy, rc, vw); });
    }
  }

  // The deepest overlap of any grain with a wall at time t, as a fraction of
  // the contact distance R_i + r_w (the measure of engine/health.hpp), and the
  // grain's index; for the run's health check.
  struct Overlap {
    double fraction = 0.0;
    std::size_t index = 0;
    const char* wall = "";
  };
  Overlap deepest(const ParticleStore<2>& p, double t) const {
    const double yb = shaker.y(t);
    const double floor_c = yb - wall_radius, top_c = yb + side_top, xc = half_width + wall_radius;
    Overlap o;
    auto note = [&](std::size_t i, double dx, double dy, const char* wall) {
      const double rc = 0.5 * p.d[i] + wall_radius, f = (rc - std::hypot(dx, dy)) / rc;
      if (f > o.fraction) o = {f, i, wall};
    };
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double x = p.x[i].x(), y = p.x[i].y(), dy = y - std::min(y, top_c);
      if (y > floor_c) note(i, 0.0, y - floor_c, "floor");
      if (x > -xc) note(i, x + xc, dy, "left wall");
      if (x < xc) note(i, x - xc, dy, "right wall");
    }
    return o;
  }

 private:
  // (dx, dy) = r_i - r_j, the grain from the virtual wall particle; rc: the
  // law's contact distance for the pair.
  template <class Law>
  GRANULAR_INLINE void touch(ParticleStore<2>& p, const Law& law, std::size_t i, double dx, double dy, double rc,
                             const V& vw) const {
    const double r2 = dx * dx + dy * dy;
    if (r2 >= rc * rc) return;
    const V dr(dx, dy), vij = p.v[i] - vw;
    const A wj = A::Zero();
    const auto c = law.pair_force(dr, r2, p.d[i], 2.0 * wall_radius, vij, p.w[i], wj, p.species[i], kWallSpecies,
                                  p.inv_m[i], wall_inv_mass);
    p.f[i] += c.f;
    p.tq[i] += c.ti;
  }
};

}  // namespace granular
