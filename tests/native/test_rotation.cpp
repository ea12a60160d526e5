// particles.rotation = false: the grains keep omega = 0 exactly while the
// contacts still exert torques, and the translational friction still acts.
// With rotation on, the same scenes spin their grains. Covers every law that
// resets the moments of inertia after the particles are made (the drum's
// linear and viscoelastic maps) and both box integrators.
#include <gtest/gtest.h>

#include <filesystem>

#include "engine/box.hpp"
#include "engine/drum.hpp"
#include "helpers.hpp"
#include "scene/scene_file.hpp"

using namespace granular;

namespace {

struct Spin {
  double max_w = 0.0;      // largest |omega| of a grain
  double max_tq = 0.0;     // largest |torque| on a grain
  double max_v = 0.0;      // largest grain speed
};

template <class Sim>
Spin spin_of(const Sim& v, int skip_species = -1) {
  Spin s;
  for (std::size_t i = 0; i < v.p.size(); ++i) {
    if (v.p.species[i] == skip_species) continue;
    s.max_w = std::max(s.max_w, static_cast<double>(v.p.w[i].norm()));
    s.max_tq = std::max(s.max_tq, static_cast<double>(v.p.tq[i].norm()));
    s.max_v = std::max(s.max_v, v.p.v[i].norm());
  }
  return s;
}

Spin small_drum(const std::string& law, bool rotation) {
  omp_set_num_threads(1);
  DrumScene s;
  s.name = "spin";
  s.length = 16;
  s.diameter = 10;
  s.law = law;
  s.rotation = rotation;
  DrumSim sim = make_drum(s);
  Spin out;
  std::visit(
      [&](auto& v) {
        for (int k = 0; k < 800; ++k) v.step();  // 4 time units: the bed rides up the wall
        out = spin_of(v);
      },
      sim);
  return out;
}

Spin small_box(const std::string& integrator, bool rotation) {
  omp_set_num_threads(1);
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  const auto path = (std::filesystem::path(src ? src : ".") / "scenes/box/f3.0_big.toml").string();
  SceneFile f(path, {"particles.count=60", "box.width=20", "box.wall_height=30", "integrator.kind=" + integrator,
                     std::string("particles.rotation=") + (rotation ? "true" : "false")});
  const BoxScene s = read_box_scene(f);
  EXPECT_EQ(s.rotation, rotation);
  BoxSim sim = make_box(s);
  Spin out;
  std::visit(
      [&](auto& v) {
        for (int k = 0; k < 6000; ++k) v.step();  // 0.3 s: falling and settling on the floor
        out = spin_of(v, kWallSpecies);
      },
      sim);
  return out;
}

}  // namespace

TEST(Rotation, DrumGrainsSpinUnlessRotationIsOff) {
  for (const char* law : {"rapaport", "linear", "viscel"}) {
    const Spin on = small_drum(law, true), off = small_drum(law, false);
    EXPECT_GT(on.max_w, 0.1) << law;
    EXPECT_EQ(off.max_w, 0.0) << law;      // exactly: the inertia is infinite
    EXPECT_GT(off.max_tq, 0.0) << law;     // the contacts' torques are there, and do nothing
    EXPECT_GT(off.max_v, 0.1) << law;      // the wall's friction still lifts the bed
  }
}

TEST(Rotation, BoxDisksSpinUnlessRotationIsOff) {
  for (const char* integrator : {"gear", "leapfrog"}) {
    const Spin on = small_box(integrator, true), off = small_box(integrator, false);
    EXPECT_GT(on.max_w, 0.01) << integrator;
    EXPECT_EQ(off.max_w, 0.0) << integrator;
    EXPECT_GT(off.max_tq, 0.0) << integrator;
  }
}

// Without rotation a grain cannot roll: on the rotating drum's wall a lone
// grain is dragged along by sliding friction and rides higher than a grain
// that can roll (which rolls back down).
TEST(Rotation, LoneGrainOnTheDrumWallRidesHigherWithoutRolling) {
  omp_set_num_threads(1);
  auto ride = [](bool rotation) {
    DrumScene s;
    s.name = "lone";
    s.length = 4;
    s.diameter = 10;
    s.rotation = rotation;
    DrumSim sim = make_drum(s);
    double max_x = 0.0;
    std::visit(
        [&](auto& v) {
          // keep one grain, at the bottom of the drum, at rest
          ParticleStore<3> one;
          one.add(Eigen::Vector3d(0.0, 0.0, -4.0), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1.0, 1.0,
                  0.5 * 0.2 * 1.0, 0);
          if (!rotation) one.freeze_rotation();
          v.p = one;
          v.init();
          for (int k = 0; k < 4000; ++k) {
            v.step();
            max_x = std::max(max_x, std::abs(v.p.x[0].x()));
          }
        },
        sim);
    return max_x;
  };
  const double rolling = ride(true), sliding = ride(false);
  std::printf("lone grain's largest sideways excursion: %g rolling, %g sliding\n", rolling, sliding);
  EXPECT_GT(sliding, rolling + 0.2);
}
