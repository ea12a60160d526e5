// One fuzz input through the scene loader, as `granular run` would take it:
// parse the text, pick the reader by scene.kind, read and validate every key,
// and (when the scene is small enough to build quickly) place the particles
// and derive the mapped laws (a MappingError there is reported, not a bug). A refusal is a SceneError; any other exception,
// a crash or a sanitizer report is a bug.
// Used by the libFuzzer target (scene_fuzzer.cpp) and the corpus replay test
// (tests/native/test_fuzz_corpus.cpp).
#pragma once
#include <cmath>
#include <string>

#include "scene/box_scene.hpp"
#include "scene/drum_scene.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"

namespace granular::fuzz {

// The fuzzer's own resource limit: a valid scene of millions of particles is
// legitimate but takes seconds to place (reading a drum places its particles),
// which libFuzzer would report as a hang. Such inputs are skipped, judged from
// the raw TOML before the loader sees them.
inline bool too_big_to_fuzz(const std::string& text) {
  toml::table t;
  try {
    t = toml::parse(text);
  } catch (const toml::parse_error&) {
    return false;  // the loader's error path is what we want to exercise
  }
  auto num = [&](const char* a, const char* b, double fallback) {
    const auto* n = t[a][b].node();
    if (n && n->is_integer()) return static_cast<double>(n->as_integer()->get());
    if (n && n->is_floating_point()) return n->as_floating_point()->get();
    return fallback;
  };
  const double drum = num("particles", "fill_density", 0.3) * num("drum", "diameter", 16.0) *
                      num("drum", "diameter", 16.0) * num("drum", "length", 128.0);
  return std::abs(drum) > 2e5 || std::abs(num("particles", "count", 950.0)) > 2e5;
}

// Returns true if the scene was accepted.
inline bool load_scene_text(const std::string& text) {
  if (too_big_to_fuzz(text)) return false;
  try {
    SceneFile f = SceneFile::from_text(text, "fuzz.toml");
    const std::string kind = f.peek_text("scene.kind");
    if (kind == "drum") {
      const DrumScene s = read_drum_scene(f);
      const double volume = 0.25 * M_PI * s.diameter * s.diameter * s.length;
      if (volume * s.fill_density < 3000.0) {
        const auto p = drum_particles(s);
        try {
          (void)map_rapaport_to_linear(s);  // as `granular info` does for every drum
        } catch (const MappingError&) {
          // reported as infeasible; a scene whose law needs it was refused above
        }
        return p.size() > 0;
      }
      return true;
    }
    if (kind == "shaken_box") {
      const BoxScene s = read_box_scene(f);
      if (s.count < 3000 && s.width < 500.0) {
        std::vector<Eigen::Vector2d> anchors;
        const auto p = box_particles(s, anchors);
        return p.size() > 0;
      }
      return true;
    }
    return false;
  } catch (const SceneError&) {
    return false;
  }
}

}  // namespace granular::fuzz
