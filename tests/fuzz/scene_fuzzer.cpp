// libFuzzer target for the scene loader (tests/fuzz/README.md).
#include <cstddef>
#include <cstdint>

#include "scene_fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  granular::fuzz::load_scene_text(std::string(reinterpret_cast<const char*>(data), size));
  return 0;
}
