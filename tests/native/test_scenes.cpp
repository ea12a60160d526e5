// The 24 drum scenes of Table I parse, and their initial states have Table I's
// particle counts (within 2 %); bad scene input fails with the file, key and reason.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "scene/drum_scene.hpp"

using namespace granular;
namespace fs = std::filesystem;

namespace {

fs::path source_dir() {
  const char* s = std::getenv("GRANULAR_SOURCE_DIR");
  return s ? fs::path(s) : fs::path(".");
}

std::string write_temp(const std::string& name, const std::string& text) {
  const auto p = fs::temp_directory_path() / name;
  std::ofstream(p) << text;
  return p.string();
}

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
