// The fused sweep (Simulation::advance): n steps in one call are bit for bit
// n calls of step(), for each kind of simulation the scenes make, on one and
// two threads; and the neighbour list's late particles hold every particle a
// row reaches out of order, the invariant the sweep's early finishing rests on.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "engine/box.hpp"
#include "engine/drum.hpp"
#include "scene/scene_file.hpp"

using namespace granular;
namespace fs = std::filesystem;

namespace {

fs::path source_dir() {
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  return fs::path(src ? src : ".");
}

DrumScene drum(const std::vector<std::string>& sets) {
  SceneFile f((source_dir() / "scenes/drum/A.toml").string(), sets);
  return read_drum_scene(f);
}

BoxScene box(const std::vector<std::string>& sets) {
  SceneFile f((source_dir() / "scenes/box/f3.0_big.toml").string(), sets);
  return read_box_scene(f);
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Every row's partners that lie in another block, or before the row's own
// particle, are late particles of their block. Returns how many such
// partners the rows list.
template <class Sim>
long expect_late_cover(const Sim& sim) {
  const auto& nl = sim.neighbors();
  const int nt = nl.threads();
  auto owner = [&](std::size_t j) {
    for (int u = 0; u < nt; ++u)
      if (j >= nl.block(u).first && j < nl.block(u).second) return u;
    return -1;
  };
  long out_of_order = 0;
  for (int u = 0; u < nt; ++u) {
    const auto [rlo, rhi] = nl.row_block(u);
    for (std::size_t i = rlo; i < rhi; ++i)
      for (std::uint32_t k = nl.begin(i); k < nl.end(i); ++k) {
        const std::uint32_t j = nl.col(u)[k];
        const int oi = owner(i), oj = owner(j);
        EXPECT_GE(oj, 0);
        if (oi != oj || j < i) {
          ++out_of_order;
          EXPECT_LT(j, nl.late_end(oj)) << "row " << i << " reaches " << j << " out of order";
        }
      }
  }
  // Late particles are a prefix of each block, not the whole of it.
  for (int u = 0; u < nt; ++u) {
    EXPECT_GE(nl.late_end(u), nl.block(u).first);
    EXPECT_LE(nl.late_end(u), nl.block(u).second);
  }
  return out_of_order;
}

// `settle` steps one at a time, then the same `steps` steps in calls of
// advance(`stretch`) on one copy and of step() on the other: the states are
// the same bits, column by column. Returns the partners listed out of order
// at the end (expect_late_cover).
template <class SimV, class Make>
long check_fused(Make make, int threads, long settle, long steps, long stretch) {
  omp_set_num_threads(threads);
  SimV a = make(), b = make();
  long out_of_order = 0;
  std::visit(
      [&](auto& va) {
        using S = std::decay_t<decltype(va)>;
        auto& vb = std::get<S>(b);
        for (long k = 0; k < settle; ++k) {
          va.step();
          vb.step();
        }
        for (long k = 0; k < steps; k += stretch) va.advance(std::min(stretch, steps - k));
        for (long k = 0; k < steps; ++k) vb.step();
        EXPECT_GT(va.neighbors().builds(), 1) << "the stretch should span list rebuilds";
        EXPECT_EQ(va.step_count, vb.step_count);
        EXPECT_EQ(0, std::memcmp(&va.time, &vb.time, sizeof(double)));
        EXPECT_TRUE(same_bits(va.p.id, vb.p.id)) << "storage order";
        EXPECT_TRUE(same_bits(va.p.x, vb.p.x)) << "positions";
        EXPECT_TRUE(same_bits(va.p.v, vb.p.v)) << "velocities";
        EXPECT_TRUE(same_bits(va.p.w, vb.p.w)) << "angular velocities";
        EXPECT_TRUE(same_bits(va.p.f, vb.p.f)) << "forces";
        EXPECT_TRUE(same_bits(va.p.tq, vb.p.tq)) << "torques";
        for (std::size_t c = 0; c < va.p.aux_v.size(); ++c) EXPECT_TRUE(same_bits(va.p.aux_v[c], vb.p.aux_v[c]));
        for (std::size_t c = 0; c < va.p.aux_a.size(); ++c) EXPECT_TRUE(same_bits(va.p.aux_a[c], vb.p.aux_a[c]));
        out_of_order = expect_late_cover(va);
      },
      a);
  omp_set_num_threads(1);
  return out_of_order;
}

}  // namespace

TEST(FusedSweep, PeriodicDrumMatchesStepByStep) {
  // Periodic ends: the last slab's rows reach the first slab across the wrap.
  const DrumScene s = drum({"drum.length=24"});
  for (int t : {1, 2}) {
    SCOPED_TRACE(t);
    EXPECT_GT(check_fused<DrumSim>([&] { return make_drum(s); }, t, 200, 600, 97), 0) << "no pair across the wrap";
  }
}

TEST(FusedSweep, CappedDrumLinearLawMatchesStepByStep) {
  const DrumScene s = drum({"drum.length=24", "drum.ends=capped", "contact.law=linear"});
  for (int t : {1, 2}) {
    SCOPED_TRACE(t);
    check_fused<DrumSim>([&] { return make_drum(s); }, t, 200, 600, 64);
  }
}

TEST(FusedSweep, ShakenBoxVerletAndGearMatchStepByStep) {
  for (const char* kind : {"integrator.kind=verlet", "integrator.kind=gear"}) {
    const BoxScene s = box({"particles.count=300", "box.width=24", "run.settle=0.02", kind});
    for (int t : {1, 2}) {
      SCOPED_TRACE(std::string(kind) + ", threads " + std::to_string(t));
      const long late = check_fused<BoxSim>([&] { return make_box(s); }, t, 300, 900, 100);
      if (t == 2) {
        EXPECT_GT(late, 0) << "no pair across the threads' blocks";
      }
    }
  }
}

TEST(FusedSweep, OneThreadInAClosedBoxHasNoLateParticles) {
  // No periodic axis and one block: every row reaches forward only.
  omp_set_num_threads(1);
  const BoxScene s = box({"particles.count=300", "box.width=24", "run.settle=0.02"});
  BoxSim sim = make_box(s);
  std::visit(
      [&](auto& v) {
        v.advance(50);
        EXPECT_EQ(v.neighbors().late_end(0), 0u);
        EXPECT_EQ(expect_late_cover(v), 0);
      },
      sim);
}
