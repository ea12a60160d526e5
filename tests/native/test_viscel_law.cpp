// YADE's viscoelastic law (contact/viscel.hpp): the mixing rule with 0 as
// absent, the clipped normal force, the uncapped viscous tangential force, the
// contact-point levers, and the drum's mapping from the linear law.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "contact/poeschel_herrmann.hpp"
#include "contact/viscel.hpp"
#include "engine/box.hpp"
#include "scene/drum_scene.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"

using namespace granular;

namespace {

using Law = ViscElLaw<3>;
using V = Eigen::Vector3d;

Law law_with(double kn, double cn, double cs) {
  Law law;
  for (auto& m : law.mat) m = {kn, cn, cs};
  return law;
}

TEST(ViscElLaw, MixingIsConsecutiveConnectionWithZeroAbsent) {
  EXPECT_DOUBLE_EQ(Law::mix(2.0, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(Law::mix(3.0, 6.0), 2.0);
  EXPECT_DOUBLE_EQ(Law::mix(0.0, 5.0), 5.0);
  EXPECT_DOUBLE_EQ(Law::mix(5.0, 0.0), 5.0);
  EXPECT_DOUBLE_EQ(Law::mix(0.0, 0.0), 0.0);
}

TEST(ViscElLaw, PairDampingIsMassWeightedAndNormalForceClipped) {
  const Law law = law_with(200.0, 10.0, 0.0);  // pair kn 100, cn = 10 m_eff
  const double mi = 1.0, mj = 3.0, meff = 0.75;
  const V dr(0.9, 0, 0);  // overlap 0.1 for d = 1
  // approaching at 1: F = 100*0.1 + 10*0.75*1
  auto a = law.pair_force(dr, dr.squaredNorm(), 1.0, 1.0, V(-1, 0, 0), V::Zero(), V::Zero(), 0, 0, 1 / mi, 1 / mj);
  EXPECT_NEAR(a.f.x(), 10.0 + 10.0 * meff, 1e-12);
  // separating fast: k delta - c v < 0 is clipped to zero, never attractive
  auto b = law.pair_force(dr, dr.squaredNorm(), 1.0, 1.0, V(5, 0, 0), V::Zero(), V::Zero(), 0, 0, 1 / mi, 1 / mj);
  EXPECT_EQ(b.f.x(), 0.0);
}

TEST(ViscElLaw, TangentialForceIsViscousAndNeverCapped) {
  const Law law = law_with(200.0, 0.0, 40.0);  // cs = 40 m_eff = 20 for unit masses
  const V dr(0.99, 0, 0);                      // overlap 0.01: F_n = 100 * 0.01 = 1
  const V vij(0, 2.0, 0);
  auto r = law.pair_force(dr, dr.squaredNorm(), 1.0, 1.0, vij, V::Zero(), V::Zero(), 0, 0, 1.0, 1.0);
  EXPECT_NEAR(r.f.x(), 1.0, 1e-12);
  EXPECT_NEAR(r.f.y(), -40.0, 1e-12);  // -20 * 2: 40 times the normal force, no Coulomb cap
  // torque lever is R - delta/2 (YADE's contact point in the middle of the overlap)
  const double lever = 0.5 - 0.005;
  EXPECT_NEAR(r.ti.z(), -lever * (1.0 * -40.0), 1e-12);  // -l (n x F_t), n = x^: (x^ x y^) = z^
  EXPECT_NEAR(r.tj.z(), r.ti.z(), 1e-12);
}

TEST(ViscElLaw, SpinEntersThroughContactPointLevers) {
  const Law law = law_with(200.0, 0.0, 10.0);
  const V dr(0.9, 0, 0);
  const V w(0, 0, 1.0);  // both spin about z: contact-point velocities cancel only with equal levers
  auto r = law.pair_force(dr, dr.squaredNorm(), 1.0, 1.0, V::Zero(), w, w, 0, 0, 1.0, 1.0);
  // v_t = -(l_i w + l_j w) x n = -(2 * 0.45) z^ x x^ = -0.9 y^; F_t = -cs v_t with cs = 5
  EXPECT_NEAR(r.f.y(), 5.0 * 0.9, 1e-12);
}

TEST(ViscElLaw, WallUsesAbsoluteWallValuesMixedWithTheParticle) {
  Law law = law_with(200.0, 10.0, 4.0);
  law.wall[0] = {200.0, 0.0, 0.0};  // kn mixes to 100; cn, cs absent: the particle's c m_i
  const double m = 2.0;
  const V rp(0, 0, 0.4);  // overlap 0.1 for d = 1
  auto r = law.wall_force(rp, 1.0, 0.0, V(1.0, 0, -1.0), V::Zero(), V::Zero(), 0, 1 / m);
  EXPECT_NEAR(r.f.z(), 100.0 * 0.1 + 10.0 * m * 1.0, 1e-12);
  EXPECT_NEAR(r.f.x(), -4.0 * m * 1.0, 1e-12);
}

TEST(ViscElMapping, SameSpeciesPairsAndWallsReproduceTheLinearLaw) {
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  const auto path = std::filesystem::path(src ? src : ".") / "scenes/drum/A.toml";
  SceneFile f(path.string(), {});
  const DrumScene s = read_drum_scene(f);
  const LinearMapping lin = map_rapaport_to_linear(s);
  const ViscElMapping v = map_linear_to_viscel(s, lin);
  EXPECT_TRUE(v.infeasible.empty());
  for (int a = 0; a < 2; ++a) {
    const double m = v.mean_mass[a];
    const auto& mat = v.law.mat[a];
    const auto& c = lin.law.pair[a * 2 + a];
    EXPECT_NEAR(Law::mix(mat.kn, mat.kn), c.kn, 1e-12 * c.kn);
    EXPECT_NEAR(Law::mix(mat.cn_per_mass * m, mat.cn_per_mass * m), c.gamma_n * m / 2, 1e-12 * c.gamma_n * m);
    EXPECT_NEAR(Law::mix(mat.cs_per_mass * m, mat.cs_per_mass * m), c.xgamma_t * c.gamma_n * m / 2,
                1e-12 * mat.cs_per_mass * m);
    const auto& w = lin.law.wall[a];
    EXPECT_NEAR(Law::mix(mat.kn, v.law.wall[a].kn), w.kn, 1e-9 * w.kn);
    EXPECT_NEAR(Law::mix(mat.cn_per_mass * m, v.law.wall[a].cn), w.gamma_n * m, 1e-9 * w.gamma_n * m);
    EXPECT_NEAR(Law::mix(mat.cs_per_mass * m, v.law.wall[a].cs), w.xgamma_t * w.gamma_n * m, 1e-9);
  }
}

// The box with contact.law = "viscel": the Poeschel-Herrmann pair and
// grain-wall-particle coefficients (k_n = Y, c_n = gamma_N m_eff, c_s =
// gamma_S m_eff) from one per-mass material per species, for unequal masses
// and for a wall particle of infinite mass; mu kept for the census.
TEST(ViscElMapping, BoxReproducesThePapersCoefficients) {
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  const auto path = std::filesystem::path(src ? src : ".") / "scenes/box/f3.0_big.toml";
  for (const char* wall_mass : {"box.wall_mass=\"particle\"", "box.wall_mass=\"infinite\""}) {
    SceneFile f(path.string(), {"contact.law=\"viscel\"", "integrator.kind=\"leapfrog\"", wall_mass});
    const BoxScene s = read_box_scene(f);
    BoxSim sim = make_box(s);
    const auto& law = std::get<ParticleWallBoxOf<ViscElLaw<2>, Leapfrog>>(sim).law;
    PoeschelHerrmannLaw<2> ph;
    ph.young = s.young;
    ph.gamma_n = s.gamma_n;
    ph.gamma_s = 1e9;  // cap always binds: only the normal component is compared here
    ph.mu = 0.0;
    const double mi = 5.0, mj = 11.0;
    const Eigen::Vector2d dr(1.99, 0.0), v(-3.0, 0.0);  // d = 2 each: overlap 0.01, approaching
    for (int cj : {0, 1, 2}) {
      const double inv_mj = (cj == 2 && s.wall_infinite_mass) ? 0.0 : 1.0 / mj;
      const auto a = law.pair_force(dr, dr.squaredNorm(), 2.0, 2.0, v, Ang<2>::Zero(), Ang<2>::Zero(), 0, cj,
                                    1.0 / mi, inv_mj);
      const auto b = ph.pair_force(dr, dr.squaredNorm(), 2.0, 2.0, v, Ang<2>::Zero(), Ang<2>::Zero(), 0, cj,
                                   1.0 / mi, inv_mj);
      EXPECT_NEAR(a.f.x(), b.f.x(), 1e-9 * std::abs(b.f.x())) << wall_mass << " species " << cj;
      // sliding at 2 along y: c_s = gamma_S m_eff, uncapped
      const Eigen::Vector2d vs(0.0, 2.0);
      const auto t = law.pair_force(dr, dr.squaredNorm(), 2.0, 2.0, vs, Ang<2>::Zero(), Ang<2>::Zero(), 0, cj,
                                    1.0 / mi, inv_mj);
      const double meff = 1.0 / (1.0 / mi + inv_mj);
      EXPECT_NEAR(t.f.y(), -s.gamma_s * meff * 2.0, 1e-9) << wall_mass << " species " << cj;
      EXPECT_EQ(law.coulomb_mu(0, cj), s.mu);
    }
  }
}

}  // namespace
