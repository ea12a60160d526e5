// Checkpoint and restart: a run continued from a checkpoint (written to disk
// and read back) is bit for bit the run that was never interrupted, for each
// kind of simulation the scenes make; and the checks that refuse a checkpoint
// that does not belong to the scene; and a run taken in one go is bit for bit
// the run taken step by step.
#include <gtest/gtest.h>
#include <omp.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "engine/box.hpp"
#include "engine/checkpoint.hpp"
#include "engine/drum.hpp"
#include "scene/scene_file.hpp"

using namespace granular;
namespace fs = std::filesystem;

namespace {

fs::path source_dir() {
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  return fs::path(src ? src : ".");
}

// This process's scratch directory, removed when its tests end.
fs::path scratch_dir() { return fs::temp_directory_path() / ("granular_ckpt_" + std::to_string(::getpid())); }

fs::path scratch(const std::string& name) {
  const fs::path d = scratch_dir();
  fs::create_directories(d);
  return d / name;
}

class RemoveScratch : public testing::Environment {
 public:
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(scratch_dir(), ignored);
  }
};
testing::Environment* const kRemoveScratch = testing::AddGlobalTestEnvironment(new RemoveScratch);

DrumScene drum(const std::vector<std::string>& sets) {
  SceneFile f((source_dir() / "scenes/drum/A.toml").string(), sets);
  return read_drum_scene(f);
}

BoxScene box(const std::vector<std::string>& sets) {
  SceneFile f((source_dir() / "scenes/box/f3.0_big.toml").string(), sets);
  return read_box_scene(f);
}

template <class T, class Alloc>
bool same_bits(const std::vector<T, Alloc>& a, const std::vector<T, Alloc>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Every column of the store, compared bit for bit in storage order.
template <class Sim>
void expect_same_state(const Sim& a, const Sim& b) {
  EXPECT_EQ(a.step_count, b.step_count);
  EXPECT_EQ(0, std::memcmp(&a.time, &b.time, sizeof(double)));
  EXPECT_TRUE(same_bits(a.p.id, b.p.id)) << "storage order";
  EXPECT_TRUE(same_bits(a.p.x, b.p.x)) << "positions";
  EXPECT_TRUE(same_bits(a.p.v, b.p.v)) << "velocities";
  EXPECT_TRUE(same_bits(a.p.w, b.p.w)) << "angular velocities";
  EXPECT_TRUE(same_bits(a.p.f, b.p.f)) << "forces";
  EXPECT_TRUE(same_bits(a.p.tq, b.p.tq)) << "torques";
  ASSERT_EQ(a.p.aux_v.size(), b.p.aux_v.size());
  for (std::size_t k = 0; k < a.p.aux_v.size(); ++k) EXPECT_TRUE(same_bits(a.p.aux_v[k], b.p.aux_v[k])) << k;
  for (std::size_t k = 0; k < a.p.aux_a.size(); ++k) EXPECT_TRUE(same_bits(a.p.aux_a[k], b.p.aux_a[k])) << k;
}

// Runs `before` steps, checkpoints through the file, runs `after` more; then a
// fresh simulation made by `make` restores the file and runs `after` steps.
// The two end states must be bitwise equal (the steps span list rebuilds).
template <class SimVariant, class Make>
void check_resume(Make make, long before, long after, const std::string& file) {
  SimVariant first = make();
  const fs::path path = scratch(file);
  std::visit(
      [&](auto& a) {
        for (long k = 0; k < before; ++k) a.step();
        CheckpointData c;
        c.scene_json = "{}";
        capture(a, c);
        write_checkpoint(path.string(), c);
        const long builds = a.neighbors().builds();
        for (long k = 0; k < after; ++k) a.step();
        ASSERT_GT(a.neighbors().builds(), builds + 2) << "the continuation should rebuild the list";

        SimVariant second_v = make();
        auto& b = std::get<std::decay_t<decltype(a)>>(second_v);
        restore(b, read_checkpoint(path.string()));
        for (long k = 0; k < after; ++k) b.step();
        expect_same_state(a, b);
      },
      first);
}

}  // namespace

TEST(Checkpoint, DrumRapaportPeriodicResumesBitwise) {
  omp_set_num_threads(2);
  const DrumScene s = drum({"drum.length=16"});
  check_resume<DrumSim>([&] { return make_drum(s); }, 700, 900, "drum_rap.ckpt");
}

TEST(Checkpoint, DrumLinearCappedResumesBitwise) {
  omp_set_num_threads(2);
  const DrumScene s = drum({"drum.length=16", "drum.ends=capped", "contact.law=linear"});
  check_resume<DrumSim>([&] { return make_drum(s); }, 700, 900, "drum_lin.ckpt");
}

TEST(Checkpoint, BoxGearResumesBitwise) {
  omp_set_num_threads(2);
  const BoxScene s = box({"particles.count=200", "box.width=24", "run.settle=0.05", "integrator.kind=gear",
                          "integrator.dt=5e-5"});
  ASSERT_EQ(s.integrator, "gear");
  // 0.05 s settling = 1000 steps; checkpoint while shaking
  check_resume<BoxSim>([&] { return make_box(s); }, 1500, 3000, "box_gear.ckpt");
}

TEST(Checkpoint, BoxLeapfrogResumesBitwise) {
  omp_set_num_threads(1);
  const BoxScene s = box({"particles.count=200", "box.width=24", "run.settle=0.05", "integrator.kind=leapfrog"});
  check_resume<BoxSim>([&] { return make_box(s); }, 1500, 3000, "box_leapfrog.ckpt");
}

// Smooth walls keep no state: the shaker's time is the run's.
TEST(Checkpoint, BoxSmoothWallsResumesBitwise) {
  omp_set_num_threads(2);
  const BoxScene s = box({"particles.count=200", "box.width=24", "run.settle=0.05", "box.walls=smooth"});
  ASSERT_TRUE(s.smooth_walls);
  check_resume<BoxSim>([&] { return make_box(s); }, 1500, 3000, "box_smooth.ckpt");
}

// What the saved reference positions are for: a list built from the current
// positions instead sorts and sums in another order, and the runs part.
TEST(Checkpoint, ListFromCurrentPositionsIsNotBitwise) {
  omp_set_num_threads(2);
  const DrumScene s = drum({"drum.length=16"});
  const fs::path path = scratch("drum_norefs.ckpt");
  DrumSim a_v = make_drum(s), b_v = make_drum(s);
  auto& a = std::get<DrumPeriodic>(a_v);
  auto& b = std::get<DrumPeriodic>(b_v);
  for (int k = 0; k < 700; ++k) a.step();
  // At a step that built the list the two are the same: go on to one that did not.
  while (same_bits(a.neighbors().reference_positions(), a.p.x)) a.step();
  CheckpointData c;
  capture(a, c);
  write_checkpoint(path.string(), c);
  restore(b, read_checkpoint(path.string()));
  b.rebuild();  // from the current positions, not the saved reference
  for (int k = 0; k < 900; ++k) {
    a.step();
    b.step();
  }
  EXPECT_FALSE(same_bits(a.p.x, b.p.x) && same_bits(a.p.id, b.p.id));
}

TEST(Checkpoint, RefusesAnotherScenesState) {
  omp_set_num_threads(1);
  DrumSim small = make_drum(drum({"drum.length=16"}));
  DrumSim large = make_drum(drum({"drum.length=24"}));
  CheckpointData c;
  std::visit([&](auto& v) { capture(v, c); }, small);
  try {
    std::visit([&](auto& v) { restore(v, c); }, large);
    FAIL() << "restored a 16-long drum's state into a 24-long one";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("wrong length"), std::string::npos) << e.what();
  }
}

// A failed write names the file and leaves the previous checkpoint and no temporary.
TEST(Checkpoint, FailedWriteKeepsThePreviousCheckpoint) {
  const fs::path path = scratch("keep.ckpt");
  CheckpointData c;
  c.step = 41;
  c.reals["x"] = {1.0, 2.0};
  write_checkpoint(path.string(), c);
  // A directory where the temporary file should go makes the next write fail.
  fs::create_directories(path.string() + ".tmp");
  c.step = 42;
  try {
    write_checkpoint(path.string(), c);
    FAIL() << "the write should have failed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
  fs::remove_all(path.string() + ".tmp");
  EXPECT_EQ(read_checkpoint(path.string()).step, 41);
}

TEST(Checkpoint, DamagedFileIsNamed) {
  const fs::path path = scratch("damaged.ckpt");
  std::ofstream(path) << "not a checkpoint";
  try {
    read_checkpoint(path.string());
    FAIL() << "read a text file as a checkpoint";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path.string()), std::string::npos) << m;
    EXPECT_NE(m.find("damaged checkpoint"), std::string::npos) << m;
  }
}

TEST(Checkpoint, RoundTripKeepsEveryField) {
  const fs::path path = scratch("fields.ckpt");
  CheckpointData c;
  c.scene_json = R"({"scene":{"name":"x"}})";
  c.engine_version = "test";
  c.threads = 2;
  c.step = 123456789012;
  c.time = 0.1 + 0.2;  // not exactly representable: must come back bit for bit
  c.seed = 77;
  c.counters = {3, 5};
  c.rows = {{"frames/time", 7}, {"profile/small_fraction", 70}};
  c.reals["v"] = {1e-300, -0.0, 3.5};
  c.ints["id"] = {2, 0, 1};
  const CheckpointData r = read_checkpoint((write_checkpoint(path.string(), c), path.string()));
  EXPECT_EQ(r.scene_json, c.scene_json);
  EXPECT_EQ(r.engine_version, c.engine_version);
  EXPECT_EQ(r.threads, 2);
  EXPECT_EQ(r.step, c.step);
  EXPECT_EQ(0, std::memcmp(&r.time, &c.time, sizeof(double)));
  EXPECT_EQ(r.seed, 77);
  EXPECT_EQ(r.counters, c.counters);
  EXPECT_EQ(r.rows, c.rows);
  EXPECT_TRUE(same_bits(r.reals.at("v"), c.reals.at("v")));
  EXPECT_EQ(r.ints.at("id"), c.ints.at("id"));
}

namespace {

// The run loop takes the steps between outputs in one call
// (Simulation::advance: one parallel region from one list rebuild to the
// next, no barrier between one step's second stage and the next one's first).
// The same steps taken one call each must give the same bits; a race between
// the steps of one region (a thread moving its particles while another still
// reads them, a ghost buffer zeroed while it is summed) shows here.
template <class SimVariant, class Make>
void check_advance(Make make, std::initializer_list<long> runs) {
  SimVariant first = make(), second = make();
  std::visit(
      [&](auto& a) {
        auto& b = std::get<std::decay_t<decltype(a)>>(second);
        const long builds = a.neighbors().builds();
        long total = 0;
        for (long n : runs) {
          a.advance(n);
          total += n;
        }
        for (long k = 0; k < total; ++k) b.step();
        ASSERT_GT(a.neighbors().builds(), builds + 2) << "the runs should span list rebuilds";
        expect_same_state(a, b);
      },
      first);
}

}  // namespace

TEST(Advance, InOneGoIsStepByStepBitwise) {
  for (int threads : {1, 2}) {
    SCOPED_TRACE(std::to_string(threads) + " thread(s)");
    omp_set_num_threads(threads);
    const DrumScene d = drum({"drum.length=16"});
    check_advance<DrumSim>([&] { return make_drum(d); }, {1, 37, 900, 2});
    for (const char* kind : {"integrator.kind=leapfrog", "integrator.kind=gear"}) {
      SCOPED_TRACE(kind);
      const BoxScene s = box({"particles.count=200", "box.width=24", "run.settle=0.05", kind});
      check_advance<BoxSim>([&] { return make_box(s); }, {1, 1499, 1500});
    }
  }
}
