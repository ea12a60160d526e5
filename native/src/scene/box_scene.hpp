// The shaken-box scene (Poeschel and Herrmann 1995): a validated plain struct
// read from a scene file, and the particles of its initial state.
#pragma once
#include <cstdint>
#include <string>

#include "contact/poeschel_herrmann.hpp"  // Damping
#include "core/particles.hpp"
#include "scene/scene_file.hpp"

namespace granular {

struct BoxScene {
  std::string name, description;
  // [box]: the paper gives none of these (docs/shaken_box.md)
  double width = 60.0;         // inner width between the side walls' surfaces, cm
  double wall_height = 100.0;  // height of the side walls above the floor surface, cm
  double wall_radius = 1.0;    // radius of the wall particles, cm
  double wall_spacing = 2.0;   // centre distance of neighbouring wall particles (2 r: touching)
  bool wall_infinite_mass = false;  // m_eff with the wall particle's own mass (false) or the grain's (true)
  // Walls of particles (the paper's) or flat walls with the same law, surfaces
  // and height (boundary/flat_box_walls.hpp); box.wall_spacing is then unused.
  bool smooth_walls = false;
  // [shaking]: y_box = A sin(2 pi f t)
  double amplitude = 2.0, frequency = 3.0, ramp_to = 3.0, ramp_start = 0.0, ramp_time = 0.0;
  double startup_cycles = 2.0;  // amplitude rises over the first cycles (avoids a jolt)
  // [particles]
  long count = 950;
  double radius_min = 0.85, radius_max = 1.15, density = 1.0;
  double inertia_factor = 0.5;  // I = inertia_factor m R^2 (grains and big disk; 1/2: a uniform disk)
  bool mass_area = false;  // false: m = 2 pi R^2 rho as printed; true: pi R^2 rho
  // false: the grains do not rotate (I = infinity, omega = 0 throughout); the
  // paper's disks rotate (the Omega terms of its Eq. (4)).
  bool rotation = true;
  std::uint64_t seed = 1;
  // [big]
  bool big = true;
  double big_radius = 4.0, big_gap = 2.0;  // gap between the floor surface and the big disk's bottom
  // [contact]
  double young = 3e6, gamma_n = 100.0, gamma_s = 1.0, mu = 0.5;
  // A registered box law's key (contact/laws.hpp): "poeschel_herrmann",
  // Eqs. (1)-(6), or "viscel", YADE's law (contact/viscel.hpp); and the reading
  // of Eq. (2)'s damping: the normal component, or |v_ij| as printed.
  std::string law = "poeschel_herrmann";
  Damping damping = Damping::normal;
  double gravity = 981.0;
  // [integrator], [neighbor]
  std::string integrator = "leapfrog";  // "leapfrog" | "gear"; defaults: box_scene.cpp
  double dt = 2e-4, skin = 0.5;  // skin: docs/shaken_box.md (speed sweep)
  // [run]: seconds
  double settle = 1.0, duration = 60.0;
  double snapshot_every_cycles = 1.0;  // frames at the vibration's node (phase 0)
  long trace_per_cycle = 20;           // big-disk samples per cycle

  double mass(double r) const;
  double cycle(double t) const;  // number of shaking cycles done at time t
};

BoxScene read_box_scene(SceneFile& f);

// Wall particles (species 2; none with smooth walls), the big disk (species 1)
// and the small disks (species 0) placed on a loose lattice above the floor;
// the initial state is then settled by the run itself. Also returns the wall
// particles' rest positions, indexed by id, and in side_top (if given) the
// height at rest of the side walls' top particle's centre, which smooth walls
// share: the walls rise to box.wall_height and at least above the packing.
ParticleStore<2> box_particles(const BoxScene& s, std::vector<Eigen::Vector2d>& anchors, double* side_top = nullptr);

}  // namespace granular
