// The particles scene (docs/particles_scene.md) end to end through its scene
// reader and run loop: a head-on collision of two spheres under Rapaport's law
// (momentum, and the restitution of scene/law_mapping.hpp's head-on
// collision), a sphere dropped on a plane wall (it rests where Eq. (1)'s
// force carries its weight), and a sphere sliding on a wall (friction, Eq. (5),
// brings it to rolling).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "engine/particles.hpp"
#include "scene/law_mapping.hpp"
#include "scene/particles_scene.hpp"
#include "scene/step_rule.hpp"

namespace granular {
namespace {

using RapSim = ParticlesSimT<RapaportLaw<3>>;

ParticlesScene scene(const std::string& text) {
  SceneFile f = SceneFile::from_text(text, "<test particles scene>");
  return read_particles_scene(f);
}

// The particle of the given id.
std::size_t index_of(const RapSim& sim, std::int64_t id) {
  for (std::size_t i = 0; i < sim.p.size(); ++i)
    if (sim.p.id[i] == id) return i;
  return sim.p.size();
}

std::string friction(double gamma_s) {
  const std::string g = std::to_string(gamma_s);
  return "[friction]\ngamma_s_bb = " + g + "\ngamma_s_ss = " + g + "\ngamma_s_bw = " + g + "\ngamma_s_sw = " + g + "\n";
}

TEST(ParticlesScene, HeadOnCollisionConservesMomentumAndHasRapaportsRestitution) {
  // Unequal speeds, so that the total momentum is not zero; equal spheres
  // (m = 1, m_eff = 1/2) approaching at relative speed 2.
  const ParticlesScene s = scene(R"(
[scene]
kind = "particles"
name = "impact"
[particles]
list = [
  {x = -0.7, y = 0.0, z = 0.0, vx = 1.5, d = 1.0, species = 0},
  {x = 0.7, y = 0.0, z = 0.0, vx = -0.5, d = 1.0, species = 0},
]
[integrator]
dt = 1e-4
[run]
duration = 0.8
)" + friction(0.0));
  ParticlesSim sim = make_particles(s);
  run_particles(s, sim, nullptr, false);
  const RapSim& v = std::get<RapSim>(sim);
  EXPECT_NEAR(v.time, 0.8, 1e-9);
  const std::size_t a = index_of(v, 0), b = index_of(v, 1);
  const Eigen::Vector3d p = v.p.v[a] / v.p.inv_m[a] + v.p.v[b] / v.p.inv_m[b];
  const double p0 = 1.5 - 0.5;
  EXPECT_NEAR(p.x(), p0, 1e-12 * p0);
  EXPECT_NEAR(p.y(), 0.0, 1e-12 * p0);
  EXPECT_NEAR(p.z(), 0.0, 1e-12 * p0);
  // Apart again, past the contact range: the rebound is complete.
  ASSERT_GT((v.p.x[b] - v.p.x[a]).norm(), RapaportLaw<3>::kCutFactor);
  const double ratio = (v.p.v[b].x() - v.p.v[a].x()) / 2.0;
  const double e = rapaport_collision(1.0, 0.5, s.gamma_n, 2.0).restitution;
  EXPECT_NEAR(ratio, e, 1e-3);
  EXPECT_GT(ratio, 0.05);  // it did rebound
}

// A sphere of d = 1 (m = 1) over the plane z = 0 with g = 5 (Rapaport's wall
// diameter d_w = 1, d_iw = 1): at rest where Eq. (1)'s force equals m g, at
// height 2^(1/6) d_iw minus Rapaport's equilibrium overlap under m g.
double rest_height(double g) { return RapaportLaw<3>::kCutFactor * 1.0 - rapaport_overlap(1.0, g); }

TEST(ParticlesScene, SphereDroppedOnAWallComesToRestOnIt) {
  const ParticlesScene s = scene(R"(
[scene]
kind = "particles"
name = "drop"
[particles]
list = [{x = 0.0, y = 0.0, z = 2.0, d = 1.0, species = 0}]
[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[gravity]
g = 5.0
[run]
duration = 20.0
)" + friction(2.0));
  ParticlesSim sim = make_particles(s);
  run_particles(s, sim, nullptr, false);
  const RapSim& v = std::get<RapSim>(sim);
  EXPECT_NEAR(v.p.x[0].z(), rest_height(5.0), 1e-3);
  EXPECT_LT(v.p.v[0].norm(), 1e-6);
  EXPECT_NEAR(v.p.x[0].x(), 0.0, 1e-12);
}

TEST(ParticlesScene, SphereSlidingOnAWallStartsRolling) {
  // Sliding at speed 1 along x, not spinning, from its rest height.
  const double h0 = rest_height(5.0);
  const ParticlesScene s = scene(R"(
[scene]
kind = "particles"
name = "slide"
[particles]
list = [{x = 0.0, y = 0.0, z = )" + std::to_string(h0) + R"(, vx = 1.0, d = 1.0, species = 0}]
[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[gravity]
g = 5.0
[run]
duration = 5.0
)" + friction(10.0));
  ParticlesSim sim = make_particles(s);
  run_particles(s, sim, nullptr, false);
  const RapSim& v = std::get<RapSim>(sim);
  const double vx = v.p.v[0].x(), wy = v.p.w[0].y(), h = v.p.x[0].z();
  EXPECT_LT(vx, 0.9);  // friction slowed it
  EXPECT_GT(vx, 0.1);
  // Rolling: the wall contact's sliding velocity v - w x r'_iw (Sec. III,
  // the paper's lever r'_iw = h z^) vanishes, v = w h.
  EXPECT_NEAR(vx, wy * h, 0.01 * vx);
  EXPECT_NEAR(v.p.v[0].y(), 0.0, 1e-12);
}

TEST(ParticlesScene, DefaultStepFollowsTheFastestParticle) {
  const std::string head = R"(
[scene]
kind = "particles"
name = "rule"
[run]
duration = 1.0
)" + friction(0.0);
  const ParticlesScene slow = scene(head + "[particles]\nlist = [{x = 0, y = 0, z = 0, vx = 1, d = 1, species = 0}]\n");
  const ParticlesScene fast = scene(head + "[particles]\nlist = [{x = 0, y = 0, z = 0, vx = 300, d = 1, species = 0}]\n");
  EXPECT_EQ(slow.dt, 0.01);
  EXPECT_LT(fast.dt, 0.01);
  const StepRule r = particles_step_rule(fast);
  EXPECT_EQ(r.impact_speed, 600.0);  // two of the fastest, head-on
  EXPECT_GE(r.contact_time / fast.dt, 4.0);
}

}  // namespace
}  // namespace granular
