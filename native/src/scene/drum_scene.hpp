// The rotating-drum scene (Rapaport 2002): a validated plain struct read from a
// scene file, and the particles of its initial state.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "scene/scene_file.hpp"

namespace granular {

struct DrumScene {
  std::string name, description;
  // [drum] geometry and drive (Table I: L, D, Omega, ends)
  double length = 128.0, diameter = 16.0, omega = 0.5;
  bool capped = false;
  double wall_diameter = 1.0;      // "the value of d associated with the wall is unity"
  std::string wall_lever = "paper";  // "paper" | "pair": see boundary/cylinder_wall.hpp
  // [particles] initial state (Table I: rho, b, Init.)
  double fill_density = 0.3, small_diameter = 1.0, big_diameter = 1.3, diameter_spread = 0.2;
  double fill_margin = 1.0, initial_speed = 1.0;
  std::string initial_state = "mixed";  // "mixed" | "segregated_band" | "segregated_halves"
  std::uint64_t seed = 1;
  // false: the grains do not rotate (I = infinity, omega = 0 throughout); the
  // paper's grains rotate ("allowing for particle rotation", Sec. III).
  bool rotation = true;
  // [contact] + [friction] (Sec. III; Table I gamma_s columns)
  std::string law = "rapaport";  // "rapaport" | "linear" (LAMMPS's law, mapped: scene/law_mapping.hpp)
  double gamma_n = 5.0, kappa = 0.2, mu_max = 0.5;
  double impact_speed = 1.0;  // speed at which the linear law matches Rapaport's collisions
  double gamma_s_bb = 10, gamma_s_ss = 2, gamma_s_bw = 10, gamma_s_sw = 2;
  double gravity = 5.0;
  // [integrator], [neighbor]
  std::string integrator = "leapfrog";
  double dt = 0.01, skin = 0.4;  // dt: drum_scene.cpp, the default step
  // [run]: lengths in rotations
  double rotations = 1.0, snapshot_every = 10.0, profile_every = 0.5, profile_slice_width = 1.0;
  // Snapshots near the end besides those every snapshot_every: the final
  // state and final_snapshots - 1 more, final_snapshot_every rotations apart
  // before it (the paper's Fig. 9: 10 configurations near the end).
  long final_snapshots = 0;
  double final_snapshot_every = 5.0;
  // [paper]: Table I reference values, reported, not used by the dynamics
  long paper_n = 0;
  double paper_rotations = 0.0;
  std::string paper_bands;

  double rotation_period() const;
  long steps_per(double rotations) const;  // steps covering that many rotations
  std::vector<long> final_snapshot_steps() const;  // the steps of the snapshots near the end, ascending
};

DrumScene read_drum_scene(SceneFile& f);

// Particles of the initial state. Lattice rule (docs/drum_scenes.md): an fcc
// lattice of int(D/a) x int(L/a) x int(D/a) cubic cells, a = (4/rho)^(1/3),
// stretched to fit the D x L x D box exactly, sites at (n + basis + 1/4) cell
// widths; sites kept inside radius D/2 - fill_margin and, at caps and at the
// boundary between segregated regions, further than fill_margin from them.
ParticleStore<3> drum_particles(const DrumScene& s);

}  // namespace granular
