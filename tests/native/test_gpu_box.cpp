// The GPU path's shaken box (gpu/box_kernels.hpp) in its host build, the same
// kernel source nvcc compiles, run as loops on the CPU, against the CPU
// engine:
// - two bodies: a disk-disk contact, a disk-wall particle contact and a
//   disk's contacts with the smooth walls through the GPU path's functions
//   give the CPU path's forces and torques to 1e-12 (the host build gives the
//   same bits: both call the law's pair_lane on the same inputs), for every
//   registered box law;
// - a small box: the same initial state (scenes/box/f3.0_big.toml shrunk,
//   through make_box) advanced both ways gives the same positions,
//   velocities and angular velocities to 1e-12 of their largest magnitude,
//   with Gear's predictor-corrector and with the leapfrog, for every box
//   law, while the shaker moves the walls of particles or the smooth walls;
// - the parts the GPU engine's run uses (gpu/box_run.hpp): a stepper made
//   from a state and its list's reference positions continues bit for bit;
//   replicas (seeds side by side in one stepper) give each seed's bits;
//   a step beyond the move limit stops the stepper before the step is
//   counted; the overlap screen against a brute-force search; the driver's
//   health check stops with the CPU engine's message.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gpu/box_kernels.hpp"
#include "gpu/box_model.hpp"
#include "gpu/box_run.hpp"
#include "scene/scene_file.hpp"

using namespace granular;

namespace {

std::string source_dir() {
  const char* s = std::getenv("GRANULAR_SOURCE_DIR");
  return s ? s : ".";
}

BoxScene box_scene(std::vector<std::string> sets) {
  SceneFile f(source_dir() + "/scenes/box/f3.0_big.toml", std::move(sets));
  return read_box_scene(f);
}

// Two disks (host memory laid out as the kernels read it) and the CPU store
// holding the same.
struct TwoDisks {
  std::vector<double> x, v, w, f, t, d, inv_m, inv_i, anchor, x_ref, disp2;
  std::vector<std::int32_t> species;
  ParticleStore<2> p;

  gpu::BoxArrays arrays() {
    return {x.data(),      v.data(),      w.data(),     f.data(),  t.data(), d.data(), inv_m.data(),
            inv_i.data(),  species.data(), anchor.data(), {},       {},       x_ref.data(), disp2.data(),
            static_cast<unsigned>(d.size())};
  }
  void add(const Eigen::Vector2d& xi, const Eigen::Vector2d& vi, double wi, double di, int ci, bool infinite) {
    const double m = di * di;
    Ang<2> w;
    w[0] = wi;
    p.add(xi, vi, w, di, m, 0.125 * m * di * di, ci);
    if (infinite) p.inv_m.back() = 0.0;
  }
  void lay_out() {
    const std::size_t n = p.size();
    for (auto* col : {&x, &v, &f, &anchor, &x_ref}) col->assign(2 * n, 0.0);
    for (auto* col : {&w, &t, &disp2}) col->assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 2; ++a) {
        x[a * n + i] = p.x[i][a];
        v[a * n + i] = p.v[i][a];
      }
      w[i] = p.w[i][0];
    }
    d.assign(p.d.begin(), p.d.end());
    inv_m.assign(p.inv_m.begin(), p.inv_m.end());
    inv_i.assign(p.inv_i.begin(), p.inv_i.end());
    species.assign(p.species.begin(), p.species.end());
  }
};

// The pair through gpu::box_pair_on_i from both sides against the CPU's
// one-contact path (LawPaths::pair_force, what the box's pair loop and the
// flat walls call), for random contacts: grain-grain, grain-big disk, and
// grain-wall particle (at rest, w = 0, of finite or infinite mass).
template <class Law>
void check_pair(const Law& law) {
  constexpr double kTol = 1e-12;
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int contacts = 0, walls = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const int kind = trial % 3;  // 0 grain-grain, 1 grain-big, 2 grain-wall
    const double di = 2.0 * std::uniform_real_distribution<double>(0.85, 1.15)(rng);
    const double dj = kind == 0 ? 2.0 * std::uniform_real_distribution<double>(0.85, 1.15)(rng) : kind == 1 ? 8.0 : 2.0;
    const int cj = kind == 0 ? 0 : kind == 1 ? 1 : kWallSpecies;
    const double phi = std::uniform_real_distribution<double>(0.0, 2.0 * M_PI)(rng);
    const double r = Law::range(di, dj) * std::uniform_real_distribution<double>(0.8, 0.99)(rng);
    const Eigen::Vector2d xi(u(rng), 5.0 + u(rng)), xj = xi - r * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    TwoDisks b;
    b.add(xi, Eigen::Vector2d(u(rng), u(rng)), 5.0 * u(rng), di, 0, false);
    b.add(xj, kind == 2 ? Eigen::Vector2d(0.0, 30.0 * u(rng)) : Eigen::Vector2d(u(rng), u(rng)),
          kind == 2 ? 0.0 : 5.0 * u(rng), dj, cj, kind == 2 && trial % 2 == 0);
    b.lay_out();
    const gpu::BoxArrays s = b.arrays();
    PairForce<2> oi, oj;
    ASSERT_TRUE(gpu::box_pair_on_i(law, s, 0, 1, oi));
    ASSERT_TRUE(gpu::box_pair_on_i(law, s, 1, 0, oj));
    const Eigen::Vector2d dr = b.p.x[0] - b.p.x[1];
    const auto cpu = law.pair_force(dr, dr.squaredNorm(), di, dj, b.p.v[0] - b.p.v[1], b.p.w[0], b.p.w[1], 0, cj,
                                    b.p.inv_m[0], b.p.inv_m[1]);
    const double fscale = cpu.f.norm(), tscale = std::max({std::abs(cpu.ti[0]), std::abs(cpu.tj[0]), 1e-300});
    ASSERT_GT(fscale, 0.0);
    for (int a = 0; a < 2; ++a) {
      EXPECT_LE(std::abs(oi.f[a] - cpu.f[a]), kTol * fscale) << Law::kName << " trial " << trial;
      EXPECT_LE(std::abs(oj.f[a] + cpu.f[a]), kTol * fscale) << Law::kName << " trial " << trial;
    }
    EXPECT_LE(std::abs(oi.ti[0] - cpu.ti[0]), kTol * tscale) << Law::kName << " trial " << trial;
    EXPECT_LE(std::abs(oj.ti[0] - cpu.tj[0]), kTol * tscale) << Law::kName << " trial " << trial;
    // Out of range: no contact either way.
    TwoDisks far = b;
    far.p.x[1] = xi - 1.01 * Law::range(di, dj) * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    far.lay_out();
    EXPECT_FALSE(gpu::box_pair_on_i(law, far.arrays(), 0, 1, oi));
    ++contacts;
    walls += kind == 2;
  }
  EXPECT_EQ(contacts, 30);
  EXPECT_EQ(walls, 10);
}

// A disk near the smooth walls (on the floor, against a side wall, in a
// bottom corner, beside a side wall's rounded top) through
// gpu::flat_walls_on_i against FlatBoxWalls::apply, while the box moves.
template <class Law>
void check_flat_walls(const Law& law) {
  constexpr double kTol = 1e-12;
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  FlatBoxWalls walls;
  walls.half_width = 6.0;
  walls.wall_radius = 1.0;
  walls.side_top = 13.0;
  walls.shaker.amplitude = 2.0;
  walls.shaker.f0 = walls.shaker.f1 = 3.0;
  int touching = 0;
  for (int trial = 0; trial < 24; ++trial) {
    walls.wall_inv_mass = trial % 2 ? 0.0 : 0.1;
    const double t = 0.01 * trial, yb = walls.shaker.y(t);
    const double di = 2.0 * std::uniform_real_distribution<double>(0.85, 1.15)(rng);
    const double gap = 0.5 * di * std::uniform_real_distribution<double>(0.8, 0.99)(rng);  // centre to surface
    const int where = trial % 4;  // floor, right wall, bottom-left corner, beside the left wall's top
    const double x = where == 0 ? 2.0 * u(rng) : where == 1 ? 6.0 - gap : -6.0 + gap;
    const double y = yb + (where == 0 || where == 2 ? gap : where == 1 ? 5.0 : 13.0 + 0.05 * gap);
    TwoDisks b;
    b.add(Eigen::Vector2d(x, y), Eigen::Vector2d(u(rng), u(rng)), 5.0 * u(rng), di, 0, false);
    b.lay_out();
    const gpu::FlatWalls2 fw{yb - walls.wall_radius, yb + walls.side_top, walls.half_width + walls.wall_radius,
                             walls.shaker.vy(t),     2.0 * walls.wall_radius, walls.wall_inv_mass};
    double f[2] = {0.0, 0.0}, tq = 0.0;
    gpu::flat_walls_on_i(law, fw, b.arrays(), 0, f, tq);
    b.p.f[0].setZero();
    b.p.tq[0].setZero();
    walls.apply(b.p, law, 0, 1, t);
    const double fscale = b.p.f[0].norm();
    ASSERT_GT(fscale, 0.0) << Law::kName << " trial " << trial;
    for (int a = 0; a < 2; ++a) EXPECT_LE(std::abs(f[a] - b.p.f[0][a]), kTol * fscale) << Law::kName << trial;
    EXPECT_LE(std::abs(tq - b.p.tq[0][0]), kTol * std::max(std::abs(b.p.tq[0][0]), 1e-300)) << Law::kName << trial;
    ++touching;
  }
  EXPECT_EQ(touching, 24);
}

TEST(GpuBox, TwoBodiesGiveTheCpuForcesForEveryLaw) {
  int laws = 0;
  for_each_type(gpu::BoxGpuLaws{}, [&](auto tag) {
    using Law = typename decltype(tag)::type;
    const Law law = Law::from_box(box_scene({}));
    SCOPED_TRACE(Law::kName);
    check_pair(law);
    check_flat_walls(law);
    ++laws;
  });
  EXPECT_EQ(laws, 3);  // poeschel_herrmann (normal, literal damping), viscel
}

// The largest difference between the CPU engine's state and the GPU path's,
// matched by id, relative to the largest magnitude of the quantity (over
// every particle and component).
struct Differences {
  double x = 0.0, v = 0.0, w = 0.0;
};
Differences compare(const ParticleStore<2>& cpu, const ParticleStore<2>& gpu) {
  std::unordered_map<std::int64_t, std::size_t> at;
  for (std::size_t k = 0; k < gpu.size(); ++k) at[gpu.id[k]] = k;
  double dx = 0.0, dv = 0.0, dw = 0.0, sx = 0.0, sv = 0.0, sw = 0.0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const std::size_t k = at.at(cpu.id[i]);
    dx = std::max(dx, (gpu.x[k] - cpu.x[i]).cwiseAbs().maxCoeff());
    dv = std::max(dv, (gpu.v[k] - cpu.v[i]).cwiseAbs().maxCoeff());
    dw = std::max(dw, std::abs(gpu.w[k][0] - cpu.w[i][0]));
    sx = std::max(sx, cpu.x[i].cwiseAbs().maxCoeff());
    sv = std::max(sv, cpu.v[i].cwiseAbs().maxCoeff());
    sw = std::max(sw, std::abs(cpu.w[i][0]));
  }
  return {dx / sx, dv / sv, dw / sw};
}

// A box 12 cm wide with 30 grains and a big disk of radius 2 cm; the shaker
// starts after 0.02 s at full amplitude (startup_cycles = 0: the floor jolts
// the bed at 2 pi f A = 38 cm/s).
BoxScene small_box(const std::string& integrator, const std::string& law, const std::string& damping,
                   const std::string& walls = "particles") {
  return box_scene({"box.width=12", "box.wall_height=14", "particles.count=30", "big.radius=2", "big.gap=1",
                    "run.settle=0.02", "shaking.startup_cycles=0", "integrator.kind=" + integrator,
                    "contact.law=" + law, "contact.damping=" + damping, "box.walls=" + walls});
}

struct Case {
  std::string integrator, law, damping, walls;
};

class GpuBoxHost : public testing::TestWithParam<Case> {};

// 400 steps (0.08 s: the grains fall onto the floor and each other, then
// the shaker moves the walls), from the state make_box builds, both ways.
// The CPU engine sums each particle's contacts in the order of its half
// neighbour list, the GPU path in the order of its full list: the same
// contact forces, bit for bit, summed in another order, so the results
// differ by rounding. 1e-12 of the largest magnitude holds for every
// quantity.
TEST_P(GpuBoxHost, FollowsTheCpuEngine) {
  constexpr long kSteps = 400;
  constexpr double kTol = 1e-12;
  const Case c = GetParam();
  const BoxScene s = small_box(c.integrator, c.law, c.damping, c.walls);
  BoxSim sim = make_box(s);
  const gpu::BoxModel model = gpu::box_model(sim);
  EXPECT_EQ(model.walls == gpu::BoxWalls::smooth, c.walls == "smooth");
  EXPECT_EQ(model.integrator, c.integrator == "gear" ? gpu::BoxIntegrator::gear : gpu::BoxIntegrator::leapfrog);
  const auto stepper = gpu::make_host_box(model);
  EXPECT_STREQ(stepper->backend(), "host");
  std::visit([&](auto& v) { v.advance(kSteps); }, sim);
  stepper->advance(kSteps);
  ParticleStore<2> got = model.p;
  stepper->download(got);
  std::visit(
      [&](auto& v) {
        EXPECT_EQ(stepper->step_count(), v.step_count);
        EXPECT_EQ(stepper->time(), v.time);
        // Not a trivial comparison: the walls moved, the grains collided
        // (their speeds changed by more than free fall alone gives).
        double wall_moved = 0.0, kicked = 0.0;
        const double fall = s.gravity * kSteps * s.dt;
        for (std::size_t i = 0; i < model.p.size(); ++i) {
          if (model.p.species[i] == kWallSpecies)
            wall_moved = std::max(wall_moved, std::abs(got.x[i].y() - model.p.x[i].y()));
          else
            kicked = std::max(kicked, (got.v[i] - model.p.v[i] - Eigen::Vector2d(0.0, -fall)).norm());
        }
        if (model.walls == gpu::BoxWalls::smooth) wall_moved = std::abs(model.shaker.y(v.time) - model.shaker.y(model.time));
        EXPECT_GT(wall_moved, 0.1);
        EXPECT_GT(kicked, 5.0);
        EXPECT_GE(stepper->builds(), 2);
        const Differences d = compare(v.p, got);
        std::printf("%s %s %s, %s walls: after %ld steps, %ld list builds: relative differences x %.3g, v %.3g, "
                    "w %.3g\n",
                    c.integrator.c_str(), c.law.c_str(), c.damping.c_str(), c.walls.c_str(), kSteps,
                    stepper->builds(), d.x, d.v, d.w);
        EXPECT_LE(d.x, kTol);
        EXPECT_LE(d.v, kTol);
        EXPECT_LE(d.w, kTol);
      },
      sim);
}

std::vector<Case> cases() {
  std::vector<Case> out;
  for (const char* walls : {"particles", "smooth"})
    for (const char* integrator : {"gear", "leapfrog"})
      for (const auto& [law, damping] : {std::pair{"poeschel_herrmann", "normal"},
                                         std::pair{"poeschel_herrmann", "literal"}, std::pair{"viscel", "normal"}})
        out.push_back({integrator, law, damping, walls});
  return out;
}

INSTANTIATE_TEST_SUITE_P(Models, GpuBoxHost, testing::ValuesIn(cases()), [](const auto& info) {
  const Case& c = info.param;
  return c.integrator + "_" + c.law + "_" + c.damping + "_" + c.walls;
});

// Stepping in pieces gives the same bits as in one go.
TEST(GpuBox, PiecesGiveTheSameBits) {
  const BoxSim sim = make_box(small_box("gear", "poeschel_herrmann", "normal"));
  const gpu::BoxModel model = gpu::box_model(sim);
  const auto a = gpu::make_host_box(model), b = gpu::make_host_box(model);
  a->advance(150);
  for (int k = 0; k < 5; ++k) b->advance(30);
  ParticleStore<2> pa = model.p, pb = model.p;
  a->download(pa);
  b->download(pb);
  EXPECT_TRUE(pa.x == pb.x && pa.v == pb.v && pa.w == pb.w && pa.aux_v == pb.aux_v);
  EXPECT_FALSE(pa.x == model.p.x);
}

// A stepper made from a state and its list's reference positions (a resumed
// run) continues as the stepper that wrote them, bit for bit, Gear's scaled
// derivatives included.
TEST(GpuBox, ResumesFromTheListsReferencePositionsBitForBit) {
  for (const char* walls : {"particles", "smooth"}) {
    const BoxSim sim = make_box(small_box("gear", "poeschel_herrmann", "normal", walls));
    const gpu::BoxModel model = gpu::box_model(sim);
    const auto whole = gpu::make_host_box(model);
    whole->advance(150);
    gpu::BoxModel saved = model;
    whole->download(saved.p);
    saved.time = whole->time();
    saved.step_count = whole->step_count();
    saved.x_ref = whole->reference_positions();
    EXPECT_FALSE(saved.x_ref == saved.p.x);  // the list was built before this step
    const auto resumed = gpu::make_host_box(std::vector<gpu::BoxModel>{saved});
    whole->advance(150);
    resumed->advance(150);
    ParticleStore<2> a = model.p, b = model.p;
    whole->download(a);
    resumed->download(b);
    EXPECT_TRUE(a.x == b.x && a.v == b.v && a.w == b.w && a.f == b.f && a.aux_v == b.aux_v && a.aux_a == b.aux_a)
        << walls;
    EXPECT_EQ(whole->time(), resumed->time());
    EXPECT_EQ(resumed->step_count(), 300);
  }
}

// Replicas: three seeds of one scene side by side in one stepper give, each,
// the bits of a stepper of that seed alone (its own list, rebuilt when its
// own particles have moved far enough, in its own cells; the one shaker
// pose a step), Gear's scaled derivatives and the list's reference positions
// included: walls of particles with Gear, and smooth walls with the leapfrog
// and no big disk (then the replicas' widest grains, which size their cells,
// differ). Replicas that do not share the integrator's dt, the walls or the
// shaker are refused.
TEST(GpuBox, ReplicasGiveEachSeedsBits) {
  struct Kind {
    const char *integrator, *walls, *big;
  };
  for (const Kind& c : {Kind{"gear", "particles", "true"}, Kind{"leapfrog", "smooth", "false"}}) {
    std::vector<gpu::BoxModel> models;
    for (int k = 0; k < 3; ++k) {
      BoxScene s = box_scene({"box.width=12", "box.wall_height=14", "particles.count=30", "big.radius=2",
                              "big.gap=1", "run.settle=0.02", "shaking.startup_cycles=0",
                              std::string("integrator.kind=") + c.integrator, std::string("box.walls=") + c.walls,
                              std::string("big.enabled=") + c.big});
      s.seed += static_cast<std::uint64_t>(k);
      models.push_back(gpu::box_model(make_box(s)));
    }
    EXPECT_FALSE(models[0].p.x == models[1].p.x) << c.walls;
    const auto together = gpu::make_host_box(models);
    EXPECT_EQ(together->replicas(), 3);
    together->advance(250);
    together->advance(150);
    EXPECT_EQ(together->step_count(), 400);
    for (int k = 0; k < 3; ++k) {
      const auto alone = gpu::make_host_box(models[k]);
      alone->advance(400);
      ParticleStore<2> a = models[k].p, b = models[k].p;
      alone->download(a);
      together->download(b, k);
      EXPECT_FALSE(a.x == models[k].p.x);
      EXPECT_TRUE(a.x == b.x && a.v == b.v && a.w == b.w && a.f == b.f && a.tq == b.tq && a.aux_v == b.aux_v &&
                  a.aux_a == b.aux_a)
          << c.walls << " replica " << k;
      EXPECT_TRUE(alone->reference_positions() == together->reference_positions(k)) << c.walls << " replica " << k;
      EXPECT_EQ(alone->time(), together->time());
    }
    std::vector<gpu::BoxModel> other = models;
    other[1].dt *= 0.5;
    EXPECT_THROW(gpu::make_host_box(other), std::invalid_argument);
    other = models;
    other[2].shaker.amplitude *= 2.0;
    other[2].flat.shaker.amplitude *= 2.0;
    EXPECT_THROW(gpu::make_host_box(other), std::invalid_argument);
  }
  EXPECT_THROW(gpu::make_host_box(std::vector<gpu::BoxModel>{}), std::invalid_argument);
}

// Particles moved in memory to the order of their cells at each list build
// (the default) give the bits of particles kept in the models' order, wall
// particles' anchors and Gear's scaled derivatives included: walls
// of particles with Gear and smooth walls with the leapfrog, two seeds side
// by side. Each seed's particles stay in its range of memory.
TEST(GpuBox, ParticlesMovedInMemoryGiveTheSameBits) {
  for (const char* kind : {"gear particles", "leapfrog smooth"}) {
    const bool gear = std::string(kind) == "gear particles";
    std::vector<gpu::BoxModel> models;
    for (int k = 0; k < 2; ++k) {
      BoxScene s = box_scene({"box.width=12", "box.wall_height=14", "particles.count=30", "big.radius=2",
                              "big.gap=1", "run.settle=0.02", "shaking.startup_cycles=0",
                              std::string("integrator.kind=") + (gear ? "gear" : "leapfrog"),
                              std::string("box.walls=") + (gear ? "particles" : "smooth")});
      s.seed += static_cast<std::uint64_t>(k);
      models.push_back(gpu::box_model(make_box(s)));
    }
    std::vector<gpu::BoxModel> in_place = models;
    for (auto& m : in_place) m.reorder = false;
    const auto moved = gpu::make_host_box(models), kept = gpu::make_host_box(in_place);
    const auto first = moved->memory_order();
    moved->advance(400);
    kept->advance(400);
    EXPECT_GE(moved->builds(), 2);
    EXPECT_FALSE(moved->memory_order() == first) << kind;
    const auto ids = kept->memory_order();
    for (std::uint32_t k = 0; k < ids.size(); ++k) ASSERT_EQ(ids[k], k) << kind;
    const auto order = moved->memory_order();
    const std::uint32_t n = static_cast<std::uint32_t>(models[0].p.size());
    bool shuffled = false;
    for (std::uint32_t k = 0; k < order.size(); ++k) {
      EXPECT_EQ(order[k] / n, k / n) << kind << ": slot " << k << " holds another seed's particle";
      shuffled = shuffled || order[k] != k;
    }
    EXPECT_TRUE(shuffled) << kind;
    for (int r = 0; r < 2; ++r) {
      ParticleStore<2> a = models[r].p, b = models[r].p;
      moved->download(a, r);
      kept->download(b, r);
      EXPECT_FALSE(a.x == models[r].p.x);
      EXPECT_TRUE(a.x == b.x && a.v == b.v && a.w == b.w && a.f == b.f && a.tq == b.tq && a.aux_v == b.aux_v &&
                  a.aux_a == b.aux_a)
          << kind << " seed " << r;
      EXPECT_TRUE(moved->reference_positions(r) == kept->reference_positions(r)) << kind << " seed " << r;
      EXPECT_EQ(moved->worst_overlap()[r], kept->worst_overlap()[r]) << kind << " seed " << r;
    }
  }
}

// A step that moves a particle further than max_step_move stops the stepper
// before the step is counted, and the CPU engine's check names the culprit
// from the downloaded state.
TEST(GpuBox, AStepBeyondTheMoveLimitStopsTheStepper) {
  BoxSim sim = make_box(small_box("leapfrog", "poeschel_herrmann", "normal"));
  gpu::BoxModel model = gpu::box_model(sim);
  model.max_step_move = 1e-4;  // cm: the falling grains pass it within a few steps
  const auto s = gpu::make_host_box(model);
  long before = -1;
  try {
    s->advance(400);
    ADD_FAILURE() << "no StepUnstable";
  } catch (const gpu::StepUnstable& e) {
    EXPECT_EQ(e.replica, 0);
    before = s->step_count();
  }
  EXPECT_GE(before, 0);
  EXPECT_LT(before, 400);
}

// The overlap screen: the largest overlap of any pair in range, over every
// pair (brute force), as a fraction of the contact distance; with smooth
// walls, of any grain with a wall (FlatBoxWalls::deepest).
TEST(GpuBox, TheOverlapScreenIsTheWorstOverlap) {
  for (const char* walls : {"particles", "smooth"}) {
    const BoxSim sim = make_box(small_box("gear", "poeschel_herrmann", "normal", walls));
    const gpu::BoxModel model = gpu::box_model(sim);
    const auto s = gpu::make_host_box(model);
    s->advance(300);
    ParticleStore<2> p = model.p;
    s->download(p);
    double worst = -INFINITY;
    using Law = PoeschelHerrmannLaw<2, Damping::normal>;
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t j = 0; j < p.size(); ++j) {
        if (i == j || (p.species[i] == kWallSpecies && p.species[j] == kWallSpecies)) continue;
        const double r = (p.x[i] - p.x[j]).norm(), rc = Law::range(p.d[i], p.d[j]);
        if (r < rc) worst = std::max(worst, (rc - r) / rc);
      }
    if (model.walls == gpu::BoxWalls::smooth) worst = std::max(worst, model.flat.deepest(p, s->time()).fraction);
    const std::vector<double> screen = s->worst_overlap();
    ASSERT_EQ(screen.size(), 1u);
    EXPECT_GT(worst, 0.0) << walls;
    EXPECT_NEAR(screen[0], worst, 1e-15) << walls;
  }
}

// The driver's health check with the overlap limit lowered: the device
// screen finds the overlap, and the CPU engine's check on the downloaded
// state stops with the message the CPU engine gives at the same step.
TEST(GpuBox, TheDriversHealthCheckStopsWithTheCpuEnginesMessage) {
  for (const char* walls : {"particles", "smooth"}) {
    const BoxScene s = small_box("gear", "poeschel_herrmann", "normal", walls);
    BoxSim gpu_sim = make_box(s), cpu_sim = make_box(s);
    const auto driver = gpu::make_box_driver(s, gpu_sim, static_cast<gpu::BoxStepperFactory>(&gpu::make_host_box));
    driver->start();
    driver->advance(300);
    std::visit([](auto& v) { v.advance(300); }, cpu_sim);
    HealthLimits lim;
    driver->check_health(lim);  // 40 %: a healthy box
    lim.max_overlap = 1e-3;
    std::string gpu_message, cpu_message;
    try {
      driver->check_health(lim);
    } catch (const UnstableError& e) {
      gpu_message = e.what();
    }
    std::visit(
        [&](auto& v) {
          try {
            check_box_health(v, lim);
          } catch (const UnstableError& e) {
            cpu_message = e.what();
          }
        },
        cpu_sim);
    EXPECT_EQ(gpu_message.rfind("simulation unstable at step 300 (t = ", 0), 0u) << gpu_message;
    EXPECT_EQ(gpu_message, cpu_message) << walls;
  }
}

}  // namespace
