// The GPU path's drum (gpu/drum_kernels.hpp) in its host build, the same
// kernel source nvcc compiles, run as loops on the CPU, against the CPU
// engine:
// - two bodies: one pair contact, one contact with the cylinder wall and one
//   with an end cap through the GPU path's functions give the CPU paths'
//   forces and torques to 1e-12 (the host build gives the same bits: both
//   call the law's lane functions on the same inputs), for every registered
//   3D law;
// - a drum: the same initial state (drum #A's scene, shortened, through
//   make_drum) advanced both ways gives the same positions, velocities and
//   angular velocities, for Rapaport's, the linear and the viscoelastic law,
//   with periodic ends and with end caps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "gpu/drum_kernels.hpp"
#include "gpu/drum_model.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"

using namespace granular;

namespace {

std::string source_dir() {
  const char* s = std::getenv("GRANULAR_SOURCE_DIR");
  return s ? s : ".";
}

DrumScene drum_a(std::vector<std::string> sets) {
  SceneFile f(source_dir() + "/scenes/drum/A.toml", std::move(sets));
  return read_drum_scene(f);
}

// Two particles (host memory laid out as the kernels read it) and the CPU
// store holding the same.
struct TwoBodies {
  std::vector<double> x, v, w, f, t, d, inv_m, inv_i, x_ref, disp2;
  std::vector<std::int32_t> species;
  ParticleStore<3> p;

  gpu::DrumArrays arrays() {
    return {x.data(), v.data(), w.data(), f.data(), t.data(), d.data(), inv_m.data(), inv_i.data(),
            species.data(), x_ref.data(), disp2.data(), static_cast<unsigned>(d.size())};
  }
  void add(const Eigen::Vector3d& xi, const Eigen::Vector3d& vi, const Eigen::Vector3d& wi, double di, int ci) {
    const double m = di * di * di;
    p.add(xi, vi, wi, di, m, 0.1 * m * di * di, ci);
  }
  // The kernels' arrays from the store.
  void lay_out() {
    const std::size_t n = p.size();
    for (auto* col : {&x, &v, &w, &f, &t, &x_ref}) col->assign(3 * n, 0.0);
    disp2.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) {
        x[a * n + i] = p.x[i][a];
        v[a * n + i] = p.v[i][a];
        w[a * n + i] = p.w[i][a];
      }
    d.assign(p.d.begin(), p.d.end());
    inv_m.assign(p.inv_m.begin(), p.inv_m.end());
    inv_i.assign(p.inv_i.begin(), p.inv_i.end());
    species.assign(p.species.begin(), p.species.end());
  }
};

Eigen::Vector3d random_vector(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

// The drum's domain along y, periodic, as gpu::Box.
gpu::Box periodic_y(double length) {
  gpu::Box b{};
  const double lo[3] = {-10.0, -0.5 * length, -10.0}, len[3] = {20.0, length, 20.0};
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = lo[a];
    b.len[a] = len[a];
    b.inv_len[a] = a == 1 ? 1.0 / len[a] : 0.0;
  }
  return b;
}

// The pair (i, j) through gpu::pair_on_i from both sides against the CPU's
// one-contact path (LawPaths::pair_force: the law's pair_lane on the
// separation Domain::min_image gives; the batch path gives the same bits,
// tests/native/test_law_battery.cpp), for each of several random contacts,
// one of them across the periodic end.
template <class Law>
void check_pair(const Law& law) {
  constexpr double kTol = 1e-12;
  const double length = 8.0;
  const gpu::Box box = periodic_y(length);
  Domain<3, true> domain;
  domain.lo = Eigen::Vector3d(box.lo[0], box.lo[1], box.lo[2]);
  domain.hi = domain.lo + Eigen::Vector3d(box.len[0], box.len[1], box.len[2]);
  domain.periodic = {false, true, false};
  domain.finalize();
  std::mt19937_64 rng(11);
  int contacts = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const double di = trial % 2 ? 1.3 : 1.0, dj = trial % 3 ? 1.0 : 1.3;
    const int ci = di > 1.1, cj = dj > 1.1;
    const double reach = Law::range(di, dj);
    // Centres 0.8 to 0.99 of the range apart; every fourth across y = +-L/2.
    Eigen::Vector3d dir = random_vector(rng, 1.0);
    if (trial % 4 == 0) dir.y() = -std::abs(dir.y()) - 1.0;  // j beyond the end
    dir.normalize();
    const double r = reach * std::uniform_real_distribution<double>(0.8, 0.99)(rng);
    Eigen::Vector3d xi = random_vector(rng, 2.0);
    if (trial % 4 == 0) xi.y() = 0.5 * length - 0.1;
    const Eigen::Vector3d xj = domain.wrapped(xi - r * dir);
    if (trial % 4 == 0) {
      EXPECT_LT(xj.y(), 0.0);
    }
    TwoBodies b;
    b.add(xi, random_vector(rng, 1.0), random_vector(rng, 1.0), di, ci);
    b.add(xj, random_vector(rng, 1.0), random_vector(rng, 1.0), dj, cj);
    b.lay_out();
    const gpu::DrumArrays s = b.arrays();
    PairForce<3> oi, oj;
    ASSERT_TRUE(gpu::pair_on_i(law, box, s, 0, 1, oi));
    ASSERT_TRUE(gpu::pair_on_i(law, box, s, 1, 0, oj));
    const Eigen::Vector3d dr = domain.min_image(b.p.x[0] - b.p.x[1]);
    const auto cpu = law.pair_force(dr, dr.squaredNorm(), di, dj, b.p.v[0] - b.p.v[1], b.p.w[0], b.p.w[1], ci, cj,
                                    b.p.inv_m[0], b.p.inv_m[1]);
    const double fscale = cpu.f.norm(), tscale = std::max(cpu.ti.norm(), cpu.tj.norm());
    ASSERT_GT(fscale, 0.0);
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(std::abs(oi.f[a] - cpu.f[a]), kTol * fscale) << Law::kName << " trial " << trial;
      EXPECT_LE(std::abs(oj.f[a] + cpu.f[a]), kTol * fscale) << Law::kName << " trial " << trial;
      EXPECT_LE(std::abs(oi.ti[a] - cpu.ti[a]), kTol * tscale) << Law::kName << " trial " << trial;
      EXPECT_LE(std::abs(oj.ti[a] - cpu.tj[a]), kTol * tscale) << Law::kName << " trial " << trial;
    }
    ++contacts;
  }
  EXPECT_EQ(contacts, 20);
}

// One particle against the cylinder through gpu::wall_on_i against the CPU
// wall (CylinderWall::apply: in SIMD batches for the laws that have them, one
// by one for the others), with both readings of the wall's lever.
template <class Law>
void check_wall(const Law& law, double d_wall) {
  constexpr double kTol = 1e-12;
  std::mt19937_64 rng(12);
  for (int lever = 0; lever < 2; ++lever)
    for (int trial = 0; trial < 10; ++trial) {
      CylinderWall cyl;
      cyl.diameter = 16.0;
      cyl.omega = 0.5;
      cyl.d_wall = d_wall;
      cyl.lever = WallLever{lever == 0 ? 1.0 : 0.0, lever == 0 ? 0.0 : 1.0};
      const double di = trial % 2 ? 1.3 : 1.0;
      const int ci = di > 1.1;
      // Inside the wall's reach: r_iw between D/2 - 0.99 range and D/2 - 0.8 range.
      const double reach = Law::range(di, d_wall);
      const double phi = std::uniform_real_distribution<double>(0.0, 2.0 * M_PI)(rng);
      const double r = 0.5 * cyl.diameter - reach * std::uniform_real_distribution<double>(0.8, 0.99)(rng);
      TwoBodies b;
      b.add(Eigen::Vector3d(r * std::cos(phi), 1.5, r * std::sin(phi)), random_vector(rng, 1.0),
            random_vector(rng, 1.0), di, ci);
      b.lay_out();
      const gpu::DrumArrays s = b.arrays();
      WallForce<3> o;
      ASSERT_TRUE(cyl.in_reach<Law>(b.p.x[0].x(), b.p.x[0].z(), di));
      ASSERT_TRUE(gpu::wall_on_i(law, cyl, s, 0, o));
      b.p.f[0].setZero();
      b.p.tq[0].setZero();
      cyl.apply(b.p, law, 0, 1, 0.0);
      const double fscale = b.p.f[0].norm(), tscale = b.p.tq[0].norm();
      ASSERT_GT(fscale, 0.0);
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(std::abs(o.f[a] - b.p.f[0][a]), kTol * fscale) << Law::kName << " trial " << trial;
        EXPECT_LE(std::abs(o.t[a] - b.p.tq[0][a]), kTol * std::max(tscale, 1e-300)) << Law::kName;
      }
    }
}

// One particle near an end cap through gpu::caps_on_i against the CPU caps
// (EndCaps::apply), both readings of the lever, near either cap.
template <class Law>
void check_caps(const Law& law, double d_wall) {
  constexpr double kTol = 1e-12;
  std::mt19937_64 rng(13);
  int touching = 0;
  for (int lever = 0; lever < 2; ++lever)
    for (int trial = 0; trial < 10; ++trial) {
      EndCaps caps;
      caps.length = 8.0;
      caps.omega = 0.5;
      caps.d_wall = d_wall;
      caps.lever = WallLever{lever == 0 ? 1.0 : 0.0, lever == 0 ? 0.0 : 1.0};
      const double di = trial % 2 ? 1.3 : 1.0;
      const int ci = di > 1.1;
      // Gap to the cap between 0.8 and 0.99 of the range; odd trials at -L/2.
      const double reach = Law::range(di, d_wall);
      const double gap = reach * std::uniform_real_distribution<double>(0.8, 0.99)(rng);
      const double y = (trial % 3 ? 1.0 : -1.0) * (0.5 * caps.length - gap);
      TwoBodies b;
      const Eigen::Vector3d xi = random_vector(rng, 5.0);
      Eigen::Vector3d vi = random_vector(rng, 1.0);
      vi.y() = std::copysign(vi.y(), y);  // approaching the cap: the dashpot adds to the spring
      b.add(Eigen::Vector3d(xi.x(), y, xi.z()), vi, random_vector(rng, 1.0), di, ci);
      b.lay_out();
      const gpu::DrumArrays s = b.arrays();
      WallForce<3> o;
      ASSERT_TRUE(caps.in_reach<Law>(y, di));
      ASSERT_TRUE(gpu::caps_on_i(law, caps, s, 0, o));
      b.p.f[0].setZero();
      b.p.tq[0].setZero();
      caps.apply(b.p, law, 0, 1, 0.0);
      const double fscale = b.p.f[0].norm(), tscale = b.p.tq[0].norm();
      ASSERT_GT(fscale, 0.0);
      // The force pushes the particle away from the cap it touches.
      EXPECT_LT(b.p.f[0].y() * y, 0.0) << Law::kName << " trial " << trial;
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(std::abs(o.f[a] - b.p.f[0][a]), kTol * fscale) << Law::kName << " trial " << trial;
        EXPECT_LE(std::abs(o.t[a] - b.p.tq[0][a]), kTol * std::max(tscale, 1e-300)) << Law::kName;
      }
      // Beyond the reach: no contact either way.
      b.x[b.d.size()] = (y > 0.0 ? 1.0 : -1.0) * (0.5 * caps.length - 1.01 * reach);
      EXPECT_FALSE(gpu::caps_on_i(law, caps, b.arrays(), 0, o));
      ++touching;
    }
  EXPECT_EQ(touching, 20);
}

TEST(GpuDrum, TwoBodiesGiveTheCpuForcesForEveryLaw) {
  int laws = 0;
  for_each_type(gpu::DrumGpuLaws{}, [&](auto tag) {
    using Law = typename decltype(tag)::type;
    const auto m = Law::from_rapaport(mapping_inputs(drum_a({})));
    SCOPED_TRACE(Law::kName);
    check_pair(m.law);
    check_wall(m.law, m.d_wall);
    check_caps(m.law, m.d_wall);
    ++laws;
  });
  EXPECT_EQ(laws, 3);  // rapaport, linear, viscel
}

// The largest difference between the CPU engine's state and the GPU path's,
// matched by id, relative to the largest magnitude of the quantity (over
// every particle and component); positions by minimum image along the
// periodic axis.
struct Differences {
  double x = 0.0, v = 0.0, w = 0.0;
};
Differences compare(const ParticleStore<3>& cpu, const ParticleStore<3>& gpu, double length) {
  std::unordered_map<std::int64_t, std::size_t> at;
  for (std::size_t k = 0; k < gpu.size(); ++k) at[gpu.id[k]] = k;
  double dx = 0.0, dv = 0.0, dw = 0.0, sx = 0.0, sv = 0.0, sw = 0.0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const std::size_t k = at.at(cpu.id[i]);
    Eigen::Vector3d e = gpu.x[k] - cpu.x[i];
    e.y() -= length * std::nearbyint(e.y() / length);
    dx = std::max(dx, e.cwiseAbs().maxCoeff());
    dv = std::max(dv, (gpu.v[k] - cpu.v[i]).cwiseAbs().maxCoeff());
    dw = std::max(dw, (gpu.w[k] - cpu.w[i]).cwiseAbs().maxCoeff());
    sx = std::max(sx, cpu.x[i].cwiseAbs().maxCoeff());
    sv = std::max(sv, cpu.v[i].cwiseAbs().maxCoeff());
    sw = std::max(sw, cpu.w[i].cwiseAbs().maxCoeff());
  }
  return {dx / sx, dv / sv, dw / sw};
}

struct DrumCase {
  std::string law, ends;
};

class GpuDrumHost : public testing::TestWithParam<DrumCase> {};

// 200 steps of drum #A shortened to L = 8 (264 particles; the initial
// collapse, so many pair and wall contacts and several list builds), with
// periodic ends or end caps, from the state make_drum builds, both ways. The CPU engine sums each
// particle's contacts in the order of its half neighbour list (a pair's
// force added to i and subtracted from j as the pair comes), the GPU path
// in the order of its full list (each particle its own side of each pair):
// the same contact forces, bit for bit, summed in another order, so the
// results differ by rounding, which the collisions then amplify. 1e-12 of
// the largest magnitude holds for every quantity; the differences measured
// (on 1 to 3 threads) are below 3e-14 with periodic ends and 1.1e-13 with
// caps.
TEST_P(GpuDrumHost, FollowsTheCpuEngine) {
  constexpr long kSteps = 200;
  constexpr double kTol = 1e-12;
  const double length = 8.0;
  const DrumCase c = GetParam();
  const bool capped = c.ends == "capped";
  const DrumScene s = drum_a({"drum.length=8", "contact.law=" + c.law, "drum.ends=" + c.ends});
  DrumSim sim = make_drum(s);
  const gpu::DrumModel model = gpu::drum_model(sim);
  EXPECT_EQ(model.capped, capped);
  EXPECT_EQ(model.periodic[1], !capped);
  const auto stepper = gpu::make_host_drum(model);
  EXPECT_STREQ(stepper->backend(), "host");
  std::visit([&](auto& v) { v.advance(kSteps); }, sim);
  stepper->advance(kSteps);
  ParticleStore<3> got = model.p;
  stepper->download(got);
  std::visit(
      [&](auto& v) {
        EXPECT_EQ(stepper->step_count(), v.step_count);
        EXPECT_EQ(stepper->time(), v.time);
        // Not a trivial comparison: the grains fell and collided.
        double moved = 0.0, y_max = 0.0;
        for (std::size_t i = 0; i < model.p.size(); ++i) {
          moved = std::max(moved, (got.v[i] - model.p.v[i]).norm());
          y_max = std::max(y_max, std::abs(got.x[i].y()));
        }
        EXPECT_GT(moved, 1.0);
        // With caps, grains pressed against them and stayed inside.
        if (capped) {
          EXPECT_GT(y_max, 0.5 * length - 1.0);
          EXPECT_LT(y_max, 0.5 * length);
        }
        EXPECT_GT(stepper->builds(), 2);
        const Differences d = compare(v.p, got, length);
        std::printf("%s %s: after %ld steps, %ld list builds: relative differences x %.3g, v %.3g, w %.3g\n",
                    c.law.c_str(), c.ends.c_str(), kSteps, stepper->builds(), d.x, d.v, d.w);
        EXPECT_LE(d.x, kTol);
        EXPECT_LE(d.v, kTol);
        EXPECT_LE(d.w, kTol);
      },
      sim);
}

INSTANTIATE_TEST_SUITE_P(Laws, GpuDrumHost,
                         testing::Values(DrumCase{"rapaport", "periodic"}, DrumCase{"linear", "periodic"},
                                         DrumCase{"viscel", "periodic"}, DrumCase{"rapaport", "capped"},
                                         DrumCase{"linear", "capped"}, DrumCase{"viscel", "capped"}),
                         [](const auto& info) { return info.param.law + "_" + info.param.ends; });

// Stepping in pieces gives the same bits as in one go.
TEST(GpuDrum, PiecesGiveTheSameBits) {
  const DrumScene s = drum_a({"drum.length=8", "drum.ends=capped"});
  const DrumSim sim = make_drum(s);
  const gpu::DrumModel model = gpu::drum_model(sim);
  const auto a = gpu::make_host_drum(model), b = gpu::make_host_drum(model);
  a->advance(60);
  for (int k = 0; k < 6; ++k) b->advance(10);
  ParticleStore<3> pa = model.p, pb = model.p;
  a->download(pa);
  b->download(pb);
  EXPECT_TRUE(pa.x == pb.x && pa.v == pb.v && pa.w == pb.w);
  EXPECT_FALSE(pa.x == model.p.x);
}

}  // namespace
