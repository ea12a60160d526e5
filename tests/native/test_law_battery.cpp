// The same two-body battery for every registered contact law
// (contact/laws.hpp), at the parameters a shipped scene gives it: the laws a
// scene of Rapaport's particles can use in 3D at drum #A's (Table I), the
// shaken box's laws in 2D at its defaults. A law added to the registry is
// tested here without a line of this file changing.
//
// Each law must:
// - push two overlapping particles at rest apart, along the line of centres;
// - exert no force where the particles just touch (the force is continuous
//   at the range);
// - obey Newton's third law: the contact seen from j is the contact seen from
//   i with every force reversed and the torques exchanged;
// - be objective: rotating the whole contact rotates the force and torques;
// - oppose sliding: the tangential force on i is against the tangential
//   relative velocity;
// - give the same bits one at a time (pair_force) as in SIMD lanes
//   (pair_force_batch): both are its pair_lane;
// and where the law has smooth walls, the wall contact likewise pushes the
// particle off the wall, vanishes at the range, is objective and opposes
// sliding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <type_traits>

#include "contact/laws.hpp"
#include "scene/box_scene.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"

using namespace granular;

namespace {

std::string source_dir() {
  const char* s = std::getenv("GRANULAR_SOURCE_DIR");
  return s ? s : ".";
}

// The law as a shipped scene sets it, and the diameter d_w of that scene's smooth walls.
template <class Law>
std::pair<Law, double> scene_law() {
  if constexpr (FromRapaport<Law, MappingInputs>::value) {
    SceneFile f(source_dir() + "/scenes/drum/A.toml", {});
    const auto m = Law::from_rapaport(mapping_inputs(read_drum_scene(f)));
    return {m.law, m.d_wall};
  } else {
    SceneFile f(source_dir() + "/scenes/box/f3.0_big.toml", {});
    return {Law::from_box(read_box_scene(f)), 0.0};
  }
}

// Wall contacts where the law has a wall lane.
template <class Law, class = void>
struct HasWallLane : std::false_type {};
template <class Law>
struct HasWallLane<Law, std::void_t<decltype(&Law::wall_lane)>> : std::true_type {};

template <class L>
struct GTestTypes;
template <class... T>
struct GTestTypes<TypeList<T...>> {
  using type = ::testing::Types<T...>;
};

using RegisteredLaws = Concat<RapaportSceneLaws<MappingInputs>, BoxSceneLaws<BoxScene>>;

template <class Law>
class LawBattery : public ::testing::Test {
 protected:
  static constexpr int D = std::is_same_v<typename Law::V, Vec<3>> ? 3 : 2;
  using V = Vec<D>;
  using A = Ang<D>;
  Law law = scene_law<Law>().first;
  double d_wall = scene_law<Law>().second;
  std::mt19937_64 gen{7};
  std::uniform_real_distribution<double> u{-1.0, 1.0};

  V random_v(double s) {
    V v;
    for (int a = 0; a < D; ++a) v[a] = s * u(gen);
    return v;
  }
  A random_w(double s) {
    A w;
    for (int a = 0; a < A::RowsAtCompileTime; ++a) w[a] = s * u(gen);
    return w;
  }
  // A rotation of the plane (2D) or of space (3D), and its action on an
  // angular vector (in 2D the z component does not change).
  Eigen::Matrix<double, D, D> rotation() {
    if constexpr (D == 2) {
      return Eigen::Rotation2Dd(0.7).toRotationMatrix();
    } else {
      return Eigen::AngleAxisd(0.9, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
    }
  }
  A rotate_ang(const Eigen::Matrix<double, D, D>& R, const A& w) {
    if constexpr (D == 2)
      return w;
    else
      return R * w;
  }
  // Species 0 and the last grain species (1: big) of the law's scene.
  struct Body {
    double d, inv_m;
    int c;
  };
  Body small() const { return {1.0, 1.0, 0}; }
  Body big() const { return {1.3, 1.0 / (1.3 * 1.3 * 1.3), 1}; }
  typename Law::PairResult force(const V& dr, const Body& i, const Body& j, const V& v, const A& wi, const A& wj) {
    return law.pair_force(dr, dr.squaredNorm(), i.d, j.d, v, wi, wj, i.c, j.c, i.inv_m, j.inv_m);
  }
};

TYPED_TEST_SUITE_P(LawBattery);

TYPED_TEST_P(LawBattery, OverlapAtRestPushesApart) {
  using V = typename TestFixture::V;
  using A = typename TestFixture::A;
  for (const auto& [i, j] : {std::pair{this->small(), this->small()}, std::pair{this->small(), this->big()}}) {
    const V dir = this->random_v(1.0).normalized();
    const double r = 0.97 * TypeParam::range(i.d, j.d);
    const auto res = this->force(r * dir, i, j, V::Zero(), A::Zero(), A::Zero());
    EXPECT_GT(res.f.dot(dir), 0.0) << TypeParam::kName;
    EXPECT_LT((res.f - res.f.dot(dir) * dir).norm(), 1e-12 * res.f.norm()) << "along the line of centres";
    EXPECT_LT(res.ti.norm() + res.tj.norm(), 1e-12 * res.f.norm()) << "no torque without sliding";
  }
}

TYPED_TEST_P(LawBattery, NoForceWhereParticlesJustTouch) {
  using V = typename TestFixture::V;
  using A = typename TestFixture::A;
  const auto i = this->small(), j = this->big();
  const V dir = this->random_v(1.0).normalized();
  const double rc = TypeParam::range(i.d, j.d);
  const double at_5pc = this->force(0.95 * rc * dir, i, j, V::Zero(), A::Zero(), A::Zero()).f.norm();
  const double at_edge = this->force((1.0 - 1e-9) * rc * dir, i, j, V::Zero(), A::Zero(), A::Zero()).f.norm();
  EXPECT_GT(at_5pc, 0.0);
  EXPECT_LT(at_edge, 1e-6 * at_5pc) << TypeParam::kName;
}

TYPED_TEST_P(LawBattery, NewtonsThirdLaw) {
  using V = typename TestFixture::V;
  for (int k = 0; k < 50; ++k) {
    const auto i = k % 2 ? this->small() : this->big(), j = this->big();
    const V dir = this->random_v(1.0).normalized();
    const V dr = (1.0 - 0.08 * std::abs(this->u(this->gen))) * TypeParam::range(i.d, j.d) * dir;
    const V v = this->random_v(k % 3 ? 0.5 : 5.0);
    const auto wi = this->random_w(0.5), wj = this->random_w(0.5);
    const auto a = this->force(dr, i, j, v, wi, wj);
    const auto b = this->force(-dr, j, i, -v, wj, wi);
    const double s = a.f.norm() + a.ti.norm() + a.tj.norm();
    EXPECT_LT((a.f + b.f).norm(), 1e-12 * s) << TypeParam::kName;
    EXPECT_LT((a.ti - b.tj).norm(), 1e-12 * s);
    EXPECT_LT((a.tj - b.ti).norm(), 1e-12 * s);
  }
}

TYPED_TEST_P(LawBattery, RotatingTheContactRotatesTheForces) {
  using V = typename TestFixture::V;
  const auto R = this->rotation();
  for (int k = 0; k < 50; ++k) {
    const auto i = this->small(), j = k % 2 ? this->small() : this->big();
    const V dr = (1.0 - 0.08 * std::abs(this->u(this->gen))) * TypeParam::range(i.d, j.d) *
                 this->random_v(1.0).normalized();
    const V v = this->random_v(1.0);
    const auto wi = this->random_w(0.5), wj = this->random_w(0.5);
    const auto a = this->force(dr, i, j, v, wi, wj);
    const auto b = this->force(R * dr, i, j, R * v, this->rotate_ang(R, wi), this->rotate_ang(R, wj));
    const double s = a.f.norm() + a.ti.norm() + a.tj.norm();
    EXPECT_LT((R * a.f - b.f).norm(), 1e-12 * s) << TypeParam::kName;
    EXPECT_LT((this->rotate_ang(R, a.ti) - b.ti).norm(), 1e-12 * s);
    EXPECT_LT((this->rotate_ang(R, a.tj) - b.tj).norm(), 1e-12 * s);
  }
}

TYPED_TEST_P(LawBattery, FrictionOpposesSliding) {
  using V = typename TestFixture::V;
  using A = typename TestFixture::A;
  for (int k = 0; k < 50; ++k) {
    const auto i = this->small(), j = this->big();
    const V n = this->random_v(1.0).normalized();
    const V dr = 0.96 * TypeParam::range(i.d, j.d) * n;
    V vt = this->random_v(std::pow(10.0, 2.0 * this->u(this->gen)));
    vt -= vt.dot(n) * n;  // sliding only: no normal relative velocity, no spin
    const auto res = this->force(dr, i, j, vt, A::Zero(), A::Zero());
    const V ft = res.f - res.f.dot(n) * n;
    EXPECT_LT(ft.dot(vt), 0.0) << TypeParam::kName << ": |v_t| = " << vt.norm();
  }
}

TYPED_TEST_P(LawBattery, OneAtATimeAndInLanesGiveTheSameBits) {
  using V = typename TestFixture::V;
  constexpr int D = TestFixture::D;
  PairBatch<D> b;
  std::vector<typename TypeParam::PairResult> expect;
  for (int q = 0; q < PairBatch<D>::kSize; ++q) {
    const auto i = q % 2 ? this->small() : this->big(), j = q % 3 ? this->small() : this->big();
    const V dr = (1.0 - 0.08 * std::abs(this->u(this->gen))) * TypeParam::range(i.d, j.d) *
                 this->random_v(1.0).normalized();
    const V v = this->random_v(q % 4 ? 0.5 : 0.0);
    const auto wi = this->random_w(0.5), wj = this->random_w(0.5);
    expect.push_back(this->force(dr, i, j, v, wi, wj));
    for (int a = 0; a < D; ++a) {
      b.dr[a][q] = dr[a];
      b.v[a][q] = v[a];
    }
    for (int a = 0; a < PairBatch<D>::kAng; ++a) {
      b.wi[a][q] = wi[a];
      b.wj[a][q] = wj[a];
    }
    b.r2[q] = dr.squaredNorm();
    b.di[q] = i.d;
    b.dj[q] = j.d;
    b.ci[q] = i.c;
    b.cj[q] = j.c;
    b.inv_mi[q] = i.inv_m;
    b.inv_mj[q] = j.inv_m;
  }
  b.n = PairBatch<D>::kSize;
  this->law.pair_force_batch(b);
  for (int q = 0; q < b.n; ++q) {
    for (int a = 0; a < D; ++a) EXPECT_EQ(b.f[a][q], expect[q].f[a]) << TypeParam::kName << " contact " << q;
    for (int a = 0; a < PairBatch<D>::kAng; ++a) {
      EXPECT_EQ(b.ti[a][q], expect[q].ti[a]) << TypeParam::kName << " contact " << q;
      EXPECT_EQ(b.tj[a][q], expect[q].tj[a]) << TypeParam::kName << " contact " << q;
    }
  }
}

TYPED_TEST_P(LawBattery, SmoothWallPushesOffAndOpposesSliding) {
  if constexpr (!HasWallLane<TypeParam>::value) {
    GTEST_SKIP() << TypeParam::kName << " meets walls made of particles only";
  } else {
    using V = typename TestFixture::V;
    using A = typename TestFixture::A;
    const auto R = this->rotation();
    const double d_wall = this->d_wall;  // d_w for Rapaport's law, zero thickness for the mapped laws
    for (int k = 0; k < 50; ++k) {
      const auto i = k % 2 ? this->small() : this->big();
      const V n = this->random_v(1.0).normalized();
      const double reach = TypeParam::range(i.d, d_wall);
      const V rp = (1.0 - 0.05 * std::abs(this->u(this->gen))) * reach * n;
      const double d_iw = 0.5 * (i.d + d_wall);
      auto wall = [&](const V& x, const V& v, const A& w) {
        return this->law.wall_force(x, i.d, d_iw, v, w, x, i.c, i.inv_m);
      };
      const auto rest = wall(rp, V::Zero(), A::Zero());
      EXPECT_GT(rest.f.dot(n), 0.0) << TypeParam::kName;
      EXPECT_LT(wall((1.0 - 1e-9) * reach * n, V::Zero(), A::Zero()).f.norm(), 1e-6 * rest.f.norm());
      V vt = this->random_v(1.0);
      vt -= vt.dot(n) * n;
      const auto slide = wall(rp, vt, A::Zero());
      EXPECT_LT((slide.f - slide.f.dot(n) * n).dot(vt), 0.0) << TypeParam::kName;
      const V v = this->random_v(1.0);
      const A w = this->random_w(0.5);
      const auto a = wall(rp, v, w), b = wall(R * rp, R * v, this->rotate_ang(R, w));
      const double s = a.f.norm() + a.t.norm();
      EXPECT_LT((R * a.f - b.f).norm(), 1e-12 * s);
      EXPECT_LT((this->rotate_ang(R, a.t) - b.t).norm(), 1e-12 * s);
    }
  }
}

REGISTER_TYPED_TEST_SUITE_P(LawBattery, OverlapAtRestPushesApart, NoForceWhereParticlesJustTouch, NewtonsThirdLaw,
                            RotatingTheContactRotatesTheForces, FrictionOpposesSliding,
                            OneAtATimeAndInLanesGiveTheSameBits, SmoothWallPushesOffAndOpposesSliding);
INSTANTIATE_TYPED_TEST_SUITE_P(Registered, LawBattery, GTestTypes<RegisteredLaws>::type);

// The registry gives every scene its keys: the drum's and the box's laws.
TEST(LawRegistry, ScenesOfferTheRegisteredLaws) {
  EXPECT_EQ(law_names(RapaportSceneLaws<MappingInputs>{}), (std::vector<std::string>{"rapaport", "linear", "viscel"}));
  EXPECT_EQ(law_names(BoxSceneLaws<BoxScene>{}), (std::vector<std::string>{"viscel", "poeschel_herrmann"}));
  EXPECT_TRUE(with_law(BoxSceneLaws<BoxScene>{}, "poeschel_herrmann", Damping::literal, [](auto) {}));
  EXPECT_FALSE(with_law(BoxSceneLaws<BoxScene>{}, "viscel", Damping::literal, [](auto) {}));
  EXPECT_FALSE(with_law(RapaportSceneLaws<MappingInputs>{}, "poeschel_herrmann", Damping::normal, [](auto) {}));
}

}  // namespace
