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
#include "gpu/drum_run.hpp"
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
  Domain<3, Wrap::periodic> domain;
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

namespace {

// The GPU path's model of drum #A at L = 8 with seed `seed`.
gpu::DrumModel model_of(std::uint64_t seed) {
  const DrumSim sim = make_drum(drum_a({"drum.length=8", "particles.seed=" + std::to_string(seed)}));
  return gpu::drum_model(sim);
}

bool same_state(const ParticleStore<3>& a, const ParticleStore<3>& b) {
  return a.x == b.x && a.v == b.v && a.w == b.w && a.f == b.f && a.tq == b.tq;
}

// Replicas side by side in one stepper (one launch per kernel for all, cells
// keyed by replica) give each the bits of a stepper of that replica alone:
// each rebuilds its list when its own particles have moved far enough.
TEST(GpuDrum, ReplicasGiveTheBitsOfEachAlone) {
  const std::vector<gpu::DrumModel> ms = {model_of(1), model_of(2), model_of(3)};
  const auto together = gpu::make_host_drum(ms);
  EXPECT_EQ(together->replicas(), 3);
  together->advance(300);
  long builds_alone = 0;
  for (int r = 0; r < 3; ++r) {
    const auto alone = gpu::make_host_drum(ms[r]);
    alone->advance(300);
    builds_alone = std::max(builds_alone, alone->builds());
    ParticleStore<3> a = ms[r].p, t = ms[r].p;
    alone->download(a);
    together->download(t, r);
    EXPECT_TRUE(same_state(a, t)) << "replica " << r;
    EXPECT_TRUE(alone->reference_positions() == together->reference_positions(r)) << "replica " << r;
    EXPECT_FALSE(a.x == ms[r].p.x);
  }
  // The replicas' lists were rebuilt at different steps: more builds of the
  // ensemble than of any replica alone.
  EXPECT_GT(together->builds(), builds_alone);
  ParticleStore<3> a = ms[0].p, b = ms[1].p;
  together->download(a, 0);
  together->download(b, 1);
  EXPECT_FALSE(a.x == b.x);
}

// Whether order holds each of the ids [offsets[r], offsets[r + 1]) in the
// same range of places, for every replica r, and is not the identity.
void expect_moved_within_replicas(const std::vector<std::uint32_t>& order, const std::vector<std::uint32_t>& offsets) {
  bool moved = false;
  for (std::size_t r = 0; r + 1 < offsets.size(); ++r) {
    std::vector<std::uint32_t> ids(order.begin() + offsets[r], order.begin() + offsets[r + 1]);
    std::sort(ids.begin(), ids.end());
    for (std::uint32_t k = 0; k < ids.size(); ++k) ASSERT_EQ(ids[k], offsets[r] + k) << "replica " << r;
    for (std::uint32_t k = offsets[r]; k < offsets[r + 1]; ++k) moved = moved || order[k] != k;
  }
  EXPECT_TRUE(moved);
}

// Particles moved in memory to the order of their cells at each list build
// (the default) give the bits of particles kept in the models' order, for
// two replicas with periodic ends and for capped ends: each particle's row
// lists the same particles in the same order wherever they are held. Each
// replica's particles stay in its range of memory.
TEST(GpuDrum, ParticlesMovedInMemoryGiveTheSameBits) {
  for (const char* ends : {"periodic", "capped"}) {
    std::vector<gpu::DrumModel> ms;
    for (int seed : {1, 2})
      ms.push_back(gpu::drum_model(make_drum(drum_a(
          {"drum.length=8", std::string("drum.ends=") + ends, "particles.seed=" + std::to_string(seed)}))));
    std::vector<gpu::DrumModel> in_place = ms;
    for (auto& m : in_place) m.reorder = false;
    const auto moved = gpu::make_host_drum(ms), kept = gpu::make_host_drum(in_place);
    const auto first = moved->memory_order();
    moved->advance(200);
    kept->advance(200);
    EXPECT_EQ(moved->builds(), kept->builds());
    EXPECT_GT(moved->builds(), 2);
    const std::uint32_t n = static_cast<std::uint32_t>(ms[0].p.size());
    expect_moved_within_replicas(first, {0, n, 2 * n});
    expect_moved_within_replicas(moved->memory_order(), {0, n, 2 * n});
    EXPECT_FALSE(moved->memory_order() == first);  // the particles moved between cells, and in memory
    const auto ids = kept->memory_order();
    for (std::uint32_t k = 0; k < ids.size(); ++k) ASSERT_EQ(ids[k], k);
    for (int r = 0; r < 2; ++r) {
      ParticleStore<3> a = ms[r].p, b = ms[r].p;
      moved->download(a, r);
      kept->download(b, r);
      EXPECT_FALSE(a.x == ms[r].p.x);
      EXPECT_TRUE(same_state(a, b)) << ends << " replica " << r;
      EXPECT_TRUE(moved->reference_positions(r) == kept->reference_positions(r)) << ends << " replica " << r;
    }
    // A stepper resumed from the moved one's download and reference positions
    // (a checkpoint) continues with the same bits.
    std::vector<gpu::DrumModel> saved = ms;
    for (int r = 0; r < 2; ++r) {
      moved->download(saved[r].p, r);
      saved[r].x_ref = moved->reference_positions(r);
      saved[r].time = moved->time();
      saved[r].step_count = moved->step_count();
    }
    const auto resumed = gpu::make_host_drum(saved);
    resumed->advance(50);
    kept->advance(50);
    for (int r = 0; r < 2; ++r) {
      ParticleStore<3> a = ms[r].p, b = ms[r].p;
      resumed->download(a, r);
      kept->download(b, r);
      EXPECT_TRUE(same_state(a, b)) << ends << " resumed replica " << r;
    }
  }
}

// A stepper made from a state and its list's reference positions (a
// checkpoint's) continues bit for bit as the stepper that state came from.
TEST(GpuDrum, ResumingFromTheListReferenceGivesTheSameBits) {
  const gpu::DrumModel m = model_of(1);
  const auto whole = gpu::make_host_drum(m);
  whole->advance(120);
  gpu::DrumModel saved = m;
  whole->download(saved.p);
  saved.x_ref = whole->reference_positions();
  saved.time = whole->time();
  saved.step_count = whole->step_count();
  EXPECT_FALSE(saved.x_ref == saved.p.x);  // the list is not the current positions'
  const auto resumed = gpu::make_host_drum(saved);
  whole->advance(180);
  resumed->advance(180);
  ParticleStore<3> a = m.p, b = m.p;
  whole->download(a);
  resumed->download(b);
  EXPECT_TRUE(same_state(a, b));
  EXPECT_EQ(whole->time(), resumed->time());
  EXPECT_EQ(whole->step_count(), resumed->step_count());
}

// A step beyond the move limit stops the stepper before the step is
// counted, naming the replica.
TEST(GpuDrum, AStepBeyondTheMoveLimitStopsNamingTheReplica) {
  std::vector<gpu::DrumModel> ms = {model_of(1), model_of(2)};
  ms[1].p.v[5] = Eigen::Vector3d(0.0, 0.0, 1e3);  // 10 per step at dt = 0.01
  for (auto& m : ms) m.max_step_move = 0.4;
  const auto s = gpu::make_host_drum(ms);
  try {
    s->advance(10);
    ADD_FAILURE() << "no StepUnstable";
  } catch (const gpu::StepUnstable& e) {
    EXPECT_EQ(e.replica, 1);
  }
  EXPECT_EQ(s->step_count(), 0);
  ParticleStore<3> p = ms[1].p;
  s->download(p, 1);
  EXPECT_NE(p.x[5].z(), ms[1].p.x[5].z());  // the state after the failing step's drift
  ms[1].p.v[5].z() = std::nan("");
  ms[1].max_step_move = INFINITY;
  ms[0].max_step_move = INFINITY;
  const auto t = gpu::make_host_drum(ms);
  EXPECT_THROW(t->advance(1), gpu::StepUnstable);
}

// The health screen's worst overlap is the largest overlap of any pair in
// range, found by brute force over every pair of the downloaded state; a
// non-finite velocity makes it +infinity.
TEST(GpuDrum, WorstOverlapIsTheBruteForceOne) {
  const gpu::DrumModel m = model_of(1);
  const auto s = gpu::make_host_drum(m);
  s->advance(250);
  ParticleStore<3> p = m.p;
  s->download(p);
  const double length = m.hi[1] - m.lo[1];
  double worst = -INFINITY;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (i == j) continue;
      Eigen::Vector3d dr = p.x[i] - p.x[j];
      dr.y() -= length * std::nearbyint(dr.y() / length);
      const double rc = RapaportLaw<3>::range(p.d[i], p.d[j]), r = dr.norm();
      if (r < rc) worst = std::max(worst, (rc - r) / rc);
    }
  ASSERT_GT(worst, 0.0);
  const std::vector<double> got = s->worst_overlap();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_NEAR(got[0], worst, 1e-12);
  gpu::DrumModel bad = m;
  bad.p.w[3].x() = INFINITY;
  EXPECT_EQ(gpu::make_host_drum(bad)->worst_overlap()[0], INFINITY);
}

// The device memory estimate: its formula, the expected list columns of a
// packing, and the sizing of drum #A's replicas.
TEST(GpuDrum, DeviceMemoryEstimate) {
  gpu::DeviceSizing z;
  z.particles = 1000;
  z.cells = 50;
  z.list_columns = 40;
  EXPECT_EQ(gpu::device_bytes(z), 1000u * (26 * 8 + (12 + 4 + 40) * 4) + 50u * 3 * 4);
  // 8 * 0.64 * 1.7^3 - 1 = 24.15: 25 columns, a quarter more and 8.
  EXPECT_EQ(gpu::expected_list_columns(1.7, 1.0), 25u + 6u + 8u);
  EXPECT_GT(gpu::expected_list_columns(2.0, 1.0), gpu::expected_list_columns(1.7, 1.0));
  const DrumSim sim = make_drum(drum_a({}));  // #A: L = 128, D = 16
  const gpu::DrumModel m = gpu::drum_model(sim);
  const gpu::DeviceSizing one = gpu::drum_sizing(m, 1), many = gpu::drum_sizing(m, 32);
  EXPECT_EQ(one.particles, m.p.size());
  EXPECT_EQ(many.particles, 32 * m.p.size());
  EXPECT_EQ(many.cells, 32 * one.cells);
  EXPECT_EQ(many.list_columns, one.list_columns);
  EXPECT_GT(one.list_columns, 20u);
  EXPECT_LT(one.list_columns, 120u);  // the smallest grains (d = 0.8) set the density
  // The longest row of a collapsed drum (L = 8, 250 steps), counted by brute
  // force within range + skin, fits the columns expected.
  const gpu::DrumModel small = model_of(1);
  const auto s = gpu::make_host_drum(small);
  s->advance(250);
  ParticleStore<3> p = small.p;
  s->download(p);
  const double length = small.hi[1] - small.lo[1];
  std::size_t longest = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    std::size_t row = 0;
    for (std::size_t j = 0; j < p.size(); ++j) {
      Eigen::Vector3d dr = p.x[i] - p.x[j];
      dr.y() -= length * std::nearbyint(dr.y() / length);
      const double reach = RapaportLaw<3>::range(p.d[i], p.d[j]) + small.skin;
      row += j != i && dr.squaredNorm() < reach * reach;
    }
    longest = std::max(longest, row);
  }
  EXPECT_GT(longest, 5u);
  EXPECT_LE(longest, gpu::drum_sizing(small, 1).list_columns);
  const std::size_t bytes = gpu::device_bytes(many);
  std::printf("32 x drum #A: %zu particles, %zu cells, %zu list columns: %.3f GiB\n", many.particles, many.cells,
              many.list_columns, static_cast<double>(bytes) / 1073741824.0);
  EXPECT_GT(bytes, many.particles * 26 * 8);
  EXPECT_LT(bytes, std::size_t{1} << 34);  // 32 x #A fits an H100's 80 GB many times over
}

// The driver's health check: the device screen finds the worst overlap, and
// engine/health.hpp's check_health on the downloaded state stops the run with
// its message, as it does the CPU engine's at the same step; within the
// limit, nothing is thrown.
TEST(GpuDrum, TheDriversHealthCheckStopsWithTheCpuEnginesMessage) {
  const DrumScene s = drum_a({"drum.length=8"});
  DrumSim gpu_sim = make_drum(s), cpu_sim = make_drum(s);
  const auto driver = gpu::make_drum_driver(s, {&gpu_sim}, static_cast<gpu::StepperFactory>(&gpu::make_host_drum));
  driver->start();
  driver->advance(150);
  std::visit([](auto& v) { v.advance(150); }, cpu_sim);
  HealthLimits lim;
  driver->check_health(lim);  // 40 %: a healthy drum
  lim.max_overlap = 1e-3;
  std::string gpu_message, cpu_message;
  try {
    driver->check_health(lim);
  } catch (const UnstableError& e) {
    gpu_message = e.what();
  }
  std::visit(
      [&](auto& v) {
        EXPECT_EQ(v.step_count, 150);
        try {
          check_health(v, lim);
        } catch (const UnstableError& e) {
          cpu_message = e.what();
        }
      },
      cpu_sim);
  const std::string start = "simulation unstable at step 150 (t = 1.5): particles id ";
  EXPECT_EQ(gpu_message.rfind(start, 0), 0u) << gpu_message;
  EXPECT_EQ(cpu_message.rfind(start, 0), 0u) << cpu_message;
  EXPECT_NE(gpu_message.find("% of their contact distance (limit 0.1 %)"), std::string::npos) << gpu_message;
  // The same pair, overlapping by the same amount to the message's 6 digits.
  EXPECT_EQ(gpu_message, cpu_message);
}

}  // namespace
