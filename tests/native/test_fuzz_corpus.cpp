// Replays the scene fuzzer's kept inputs (tests/fuzz/corpus/): each must be
// accepted or refused with a SceneError, never anything else. Under the
// sanitizer build (scripts/sanitize.sh) they must also run clean.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../fuzz/scene_fuzz.hpp"

namespace fs = std::filesystem;

TEST(FuzzCorpus, EveryInputIsAcceptedOrRefusedCleanly) {
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  const fs::path dir = fs::path(src ? src : ".") / "tests/fuzz/corpus";
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  int n = 0, accepted = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::ifstream in(e.path(), std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    try {
      accepted += granular::fuzz::load_scene_text(ss.str()) ? 1 : 0;
    } catch (const std::exception& ex) {
      ADD_FAILURE() << e.path() << ": " << typeid(ex).name() << ": " << ex.what();
    }
    ++n;
  }
  EXPECT_GE(n, 20) << "the corpus should hold the fuzzer's kept inputs";
  // Both paths are exercised: some inputs are valid scenes, most are not.
  EXPECT_GT(accepted, 0);
  EXPECT_LT(accepted, n);
}
