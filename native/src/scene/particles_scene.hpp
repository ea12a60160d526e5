// The particles scene (docs/particles_scene.md): explicit spheres and infinite
// plane walls under the drum's contact laws (Rapaport 2002, Eqs. (1)-(5), or
// the linear and viscoelastic laws mapped from them), for tests set up by hand
// (a two-sphere impact, a sphere on a wall) or a native run started from
// another engine's state (one frame of the common schema,
// docs/output_schema.md). A validated plain struct read from a scene file.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"

namespace granular {

struct ParticlesScene {
  struct Sphere {
    Eigen::Vector3d x = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
    double d = 1.0;
    int species = 0;  // 0 small, 1 big
  };
  struct Wall {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // normalised; the particles' side
  };

  std::string name, description;
  // [particles]: the spheres, from particles.list, particles.csv or one frame
  // of particles.h5 (source names which)
  std::vector<Sphere> spheres;
  std::string source;
  // [[wall]]
  std::vector<Wall> walls;
  // [contact] + [friction], as in the drum (drum_scene.hpp)
  std::string law = "rapaport";
  double gamma_n = 5.0, kappa = 0.2, mu_max = 0.5, impact_speed = 1.0;
  double gamma_s_bb = 0, gamma_s_ss = 0, gamma_s_bw = 0, gamma_s_sw = 0;
  double wall_diameter = 1.0;
  std::string wall_lever = "paper";  // "paper" | "pair": see boundary/wall_contact.hpp
  // [gravity]: g along -z
  double gravity = 0.0;
  // [integrator], [neighbor]
  double dt = 0.01, skin = 0.4;
  // [run]: time units
  double duration = 1.0, snapshot_every = 0.01;

  // Derived from the initial state, for the step rule and the health checks.
  double max_speed = 0.0;      // the fastest particle
  double release_speed = 0.0;  // sqrt(2 U_0 / m_min): the initial overlaps' energy (Eq. (1)'s potential) in the lightest particle
  double height = 0.0;         // the particles' extent along z plus the largest diameter (free fall)
  double d_min = 1.0, d_max = 1.0;

  long steps_per(double time) const;  // steps covering that time
};

ParticlesScene read_particles_scene(SceneFile& f);

// The particles of the initial state: m = d^3, I = kappa m d^2 / 2 (Sec. III).
ParticleStore<3> particles_store(const ParticlesScene& s);

// The law mapping's inputs (scene/law_mapping.hpp): each species' mean
// diameter (the other species' where it has none), the static load of a
// column as high as the particles' extent along z.
MappingInputs mapping_inputs(const ParticlesScene& s);

}  // namespace granular
