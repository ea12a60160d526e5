// The 24 drum scenes of Table I parse, and their initial states have Table I's
// particle counts (within 2 %); bad scene input fails with the file, key and reason.
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "scene/drum_scene.hpp"

using namespace granular;
namespace fs = std::filesystem;

namespace {

fs::path source_dir() {
  const char* s = std::getenv("GRANULAR_SOURCE_DIR");
  return s ? fs::path(s) : fs::path(".");
}

// A name of this process's own: ctest runs the tests of this file in parallel
// processes, which must not write one another's scene files.
fs::path temp_path(const std::string& name) {
  return fs::temp_directory_path() / (std::to_string(::getpid()) + "_" + name);
}

std::string write_temp(const std::string& name, const std::string& text) {
  const auto p = temp_path(name);
  std::ofstream(p) << text;
  return p.string();
}

// Removes a temporary file when the scope ends, however the test leaves it.
struct RemovedAtExit {
  std::string path;
  ~RemovedAtExit() {
    std::error_code ignored;
    fs::remove(path, ignored);
  }
};

const char* kMinimal = R"(
[scene]
kind = "drum"
name = "t"
[drum]
length = 32.0
diameter = 10.0
omega = 0.5
ends = "periodic"
[particles]
fill_density = 0.3
big_diameter = 1.3
initial_state = "mixed"
[friction]
gamma_s_bb = 10.0
gamma_s_ss = 2.0
gamma_s_bw = 10.0
gamma_s_sw = 2.0
[run]
rotations = 1.0
)";

std::string error_of(const std::string& text, const std::vector<std::string>& sets = {}) {
  const auto path = write_temp("granular_scene_test.toml", text);
  const RemovedAtExit removed{path};
  try {
    SceneFile f(path, sets);
    read_drum_scene(f);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Scenes, AllTableIRunsWithinTwoPercentOfPaperN) {
  const std::string ids = "ABCDEFGHIJKLMNPQRSTUVWXY";
  ASSERT_EQ(ids.size(), 24u);
  for (char id : ids) {
    const auto path = source_dir() / "scenes" / "drum" / (std::string(1, id) + ".toml");
    ASSERT_TRUE(fs::exists(path)) << path;
    SceneFile f(path.string(), {});
    const DrumScene s = read_drum_scene(f);
    EXPECT_EQ(s.name, std::string(1, id));
    ASSERT_GT(s.paper_n, 0);
    const auto p = drum_particles(s);
    EXPECT_NEAR(static_cast<double>(p.size()) / s.paper_n, 1.0, 0.02) << id << ": " << p.size() << " vs " << s.paper_n;
    // no two initial particles overlap (the lattice spacing exceeds the largest range)
    if (p.size() < 6000) {
      double closest = 1e9;
      for (std::size_t i = 0; i < p.size(); ++i)
        for (std::size_t j = i + 1; j < p.size(); ++j) {
          Eigen::Vector3d dr = p.x[i] - p.x[j];
          if (!s.capped) dr.y() -= s.length * std::nearbyint(dr.y() / s.length);
          closest = std::min(closest, dr.norm() / (0.5 * (p.d[i] + p.d[j])));
        }
      EXPECT_GT(closest, 1.0) << id;
    }
    // every particle inside the drum, clear of the wall
    for (const auto& x : p.x) ASSERT_LT(std::hypot(x.x(), x.z()), 0.5 * s.diameter - 0.5) << id;
  }
}

TEST(Scenes, MixedStateHasEqualSpeciesAndPaperMasses) {
  SceneFile f((source_dir() / "scenes/drum/A.toml").string(), {});
  const auto s = read_drum_scene(f);
  const auto p = drum_particles(s);
  long big = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    big += p.species[i];
    const double nominal = p.species[i] ? 1.3 : 1.0;
    EXPECT_LE(p.d[i], nominal);
    EXPECT_GE(p.d[i], nominal - 0.2);
    EXPECT_DOUBLE_EQ(1.0 / p.inv_m[i], p.d[i] * p.d[i] * p.d[i]);  // m = d^3
  }
  EXPECT_EQ(2 * big, static_cast<long>(p.size()));
}

TEST(Scenes, SegregatedBandHasSmallInTheMiddle) {
  SceneFile f((source_dir() / "scenes/drum/V.toml").string(), {});
  const auto s = read_drum_scene(f);
  const auto p = drum_particles(s);
  for (std::size_t i = 0; i < p.size(); ++i)
    EXPECT_EQ(p.species[i] == 0, std::abs(p.x[i].y()) < 0.25 * s.length) << p.x[i].y();
}

TEST(Scenes, OverridesApply) {
  SceneFile f((source_dir() / "scenes/drum/A.toml").string(), {"run.rotations=60", "drum.ends=capped"});
  const auto s = read_drum_scene(f);
  EXPECT_DOUBLE_EQ(s.rotations, 60.0);
  EXPECT_TRUE(s.capped);
}

TEST(Scenes, ErrorsNameFileKeyAndReason) {
  EXPECT_EQ(error_of(kMinimal), "");
  const std::string misspelt = error_of(std::string(kMinimal) + "[neighbor]\nskn = 0.3\n");
  EXPECT_NE(misspelt.find("granular_scene_test.toml"), std::string::npos) << misspelt;
  EXPECT_NE(misspelt.find("neighbor.skn"), std::string::npos) << misspelt;
  EXPECT_NE(misspelt.find("unknown key"), std::string::npos) << misspelt;
  const std::string negative = error_of(kMinimal, {"drum.diameter=-4"});
  EXPECT_NE(negative.find("drum.diameter"), std::string::npos);
  EXPECT_NE(negative.find("> 0"), std::string::npos);
  const std::string choice = error_of(kMinimal, {"drum.ends=open"});
  EXPECT_NE(choice.find("drum.ends"), std::string::npos);
  EXPECT_NE(choice.find("periodic"), std::string::npos);
  const std::string type = error_of(kMinimal, {"drum.length=\"long\""});
  EXPECT_NE(type.find("drum.length"), std::string::npos);
  EXPECT_NE(type.find("must be a number"), std::string::npos);
  const std::string missing = error_of(std::string(kMinimal).replace(std::string(kMinimal).find("omega"), 11, ""));
  EXPECT_NE(missing.find("drum.omega"), std::string::npos) << missing;
  EXPECT_NE(missing.find("missing"), std::string::npos);
  const std::string syntax = error_of("[scene\nkind=");
  EXPECT_NE(syntax.find("not a valid TOML file"), std::string::npos);
}

TEST(Scenes, ErrorsGiveTheLineAndTheNearestKey) {
  const std::string path = temp_path("granular_scene_test.toml").string();
  // kMinimal opens with a newline: [neighbor] lands on line 21, skn on 22.
  EXPECT_EQ(error_of(std::string(kMinimal) + "[neighbor]\nskn = 0.3\n"),
            path + ":22: neighbor.skn: unknown key; did you mean neighbor.skin?");
  EXPECT_EQ(error_of(kMinimal, {"neighbor.skn=0.3"}),
            path + ": neighbor.skn (--set): unknown key; did you mean neighbor.skin?");
  // a misspelt required key is reported as misspelt, not as missing
  std::string text = kMinimal;
  text.replace(text.find("diameter = 10.0"), 8, "diamter");
  EXPECT_EQ(error_of(text), path + ":7: drum.diamter: unknown key; did you mean drum.diameter?");
  EXPECT_EQ(error_of(kMinimal, {"drum.length=0"}), path + ": drum.length (--set): must be > 0, got 0");
  EXPECT_EQ(did_you_mean("skn", {"skin", "dt"}), "skin");
  EXPECT_EQ(did_you_mean("neighbour.skin", {"neighbor.skin", "drum.length"}), "neighbor.skin");
  EXPECT_EQ(did_you_mean("drum.skin", {"neighbor.skin", "drum.length"}), "neighbor.skin");
  EXPECT_EQ(did_you_mean("rapaprot", {"rapaport", "linear", "viscel"}), "rapaport");
  EXPECT_EQ(did_you_mean("colour", {"rapaport", "linear", "viscel"}), "");
}

TEST(Scenes, ParticlesThatCannotBePlacedAreRefused) {
  EXPECT_NE(error_of(kMinimal, {"particles.fill_density=0.9"}).find("cannot be packed"), std::string::npos);
  EXPECT_EQ(error_of(kMinimal, {"particles.fill_density=0.64"}), "");  // just below sqrt(2)/1.3^3
  EXPECT_NE(error_of(kMinimal, {"drum.diameter=3.5"}).find("too small for its particles"), std::string::npos);
  EXPECT_NE(error_of(kMinimal, {"particles.fill_margin=0.5"}).find("through the drum wall"), std::string::npos);
}

// ---- shaken box ----------------------------------------------------------

#include "integrate/motion.hpp"
#include "scene/box_scene.hpp"

TEST(BoxScenes, AllParseWithThePapersGrainsAndWalls) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(source_dir() / "scenes" / "box")) {
    if (e.path().extension() != ".toml") continue;
    ++n;
    SceneFile f(e.path().string(), {});
    const BoxScene s = read_box_scene(f);
    std::vector<Eigen::Vector2d> anchors;
    const auto p = box_particles(s, anchors);
    long grains = 0, big = 0, walls = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      grains += p.species[i] == 0;
      big += p.species[i] == 1;
      walls += p.species[i] == kWallSpecies;
      if (p.species[i] == 0) {
        EXPECT_GE(p.d[i], 2 * 0.85);
        EXPECT_LE(p.d[i], 2 * 1.15);
        const double r = 0.5 * p.d[i];
        EXPECT_DOUBLE_EQ(1.0 / p.inv_m[i], 2 * M_PI * r * r);  // m = 2 pi R^2 rho, rho = 1
      }
    }
    EXPECT_EQ(grains, 950) << e.path();
    EXPECT_EQ(big, s.big ? 1 : 0) << e.path();
    EXPECT_EQ(static_cast<std::size_t>(walls), anchors.size());
    // no initial overlaps among grains and the big disk
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t j = i + 1; j < p.size(); ++j)
        if (p.species[i] != kWallSpecies && p.species[j] != kWallSpecies) {
          ASSERT_GT((p.x[i] - p.x[j]).norm(), 0.5 * (p.d[i] + p.d[j])) << e.path();
        }
  }
  EXPECT_EQ(n, 13);  // 2.6/2.8/3.0 Hz with and without the big disk, five radii, two ramps
}

TEST(BoxScenes, WallGapsThatLeakAreRejected) {
  const auto path = (source_dir() / "scenes/box/f3.0_big.toml").string();
  SceneFile f(path, {"box.wall_spacing=4.0"});
  try {
    read_box_scene(f);
    FAIL() << "accepted a wall spacing that lets grains through";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("box.wall_spacing"), std::string::npos);
  }
}

TEST(BoxScenes, ShakerFollowsTheSine) {
  ShakerMotion<2> m;
  m.amplitude = 2.0;
  m.f0 = m.f1 = 3.0;
  m.start = 1.0;
  for (double t : {1.01, 1.3, 2.77, 10.0}) {
    EXPECT_NEAR(m.y(t), 2.0 * std::sin(2 * M_PI * 3.0 * (t - 1.0)), 1e-12);
    EXPECT_NEAR(m.vy(t), 2.0 * 2 * M_PI * 3.0 * std::cos(2 * M_PI * 3.0 * (t - 1.0)), 1e-9);
  }
  EXPECT_EQ(m.y(0.5), 0.0);
  // a ramp 2 -> 4 Hz over 10 s: the phase is the integral of f
  m.f1 = 4.0;
  m.f0 = 2.0;
  m.ramp_time = 10.0;
  EXPECT_NEAR(m.phase(1.0 + 10.0) / (2 * M_PI), 30.0, 1e-12);  // mean frequency 3 Hz over 10 s
  EXPECT_NEAR(m.frequency(1.0 + 5.0), 3.0, 1e-12);
  // velocity is the derivative of position, also during the start-up envelope
  m.startup_cycles = 2.0;
  for (double t : {1.2, 1.9, 5.0}) {
    const double h = 1e-6;
    EXPECT_NEAR(m.vy(t), (m.y(t + h) - m.y(t - h)) / (2 * h), 1e-5);
  }
}

// box.walls: the paper's walls of particles by default, flat walls on request;
// anything else is refused naming the file, the line, the key and the choices.
TEST(BoxScenes, WallKindIsReadAndABadOneRefused) {
  const auto path = (source_dir() / "scenes/box/f3.0_big.toml").string();
  {
    SceneFile f(path, {});
    EXPECT_FALSE(read_box_scene(f).smooth_walls);
  }
  {
    SceneFile f(path, {"box.walls=smooth"});
    const BoxScene s = read_box_scene(f);
    EXPECT_TRUE(s.smooth_walls);
    std::vector<Eigen::Vector2d> anchors;
    double top = 0;
    const auto p = box_particles(s, anchors, &top);
    EXPECT_TRUE(anchors.empty());
    for (auto sp : p.species) EXPECT_NE(sp, kWallSpecies);
    EXPECT_GE(top, s.wall_height);
    // no wall particles, so no gaps between them to refuse
    SceneFile g(path, {"box.walls=smooth", "box.wall_spacing=4.0"});
    EXPECT_NO_THROW(read_box_scene(g));
  }
  std::string text;
  {
    std::ifstream in(path);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto at = text.find("wall_spacing = 2.0\n");
  ASSERT_NE(at, std::string::npos);
  text.insert(at, "walls = \"flat\"\n");
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
  const auto bad = write_temp("granular_box_walls_test.toml", text);
  const RemovedAtExit removed{bad};
  try {
    SceneFile f(bad, {});
    read_box_scene(f);
    FAIL() << "accepted box.walls = \"flat\"";
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()), bad + ":" + std::to_string(line) +
                                         ": box.walls: unknown value \"flat\" (allowed: \"particles\", \"smooth\")");
  }
  try {
    SceneFile f(path, {"box.walls=smoth"});
    read_box_scene(f);
    FAIL() << "accepted box.walls = \"smoth\"";
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": box.walls (--set): unknown value \"smoth\"; did you mean \"smooth\"? "
                                            "(allowed: \"particles\", \"smooth\")");
  }
}
