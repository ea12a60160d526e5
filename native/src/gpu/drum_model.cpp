#include "gpu/drum_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace granular::gpu {

static_assert(std::is_same_v<VariantOf<DrumLaws>, DrumGpuLaw>,
              "the GPU drum's laws (gpu/drum_gpu.hpp) are the CPU drum's (engine/drum.hpp)");

DrumModel drum_model(const DrumSim& sim) {
  return std::visit(
      [](const auto& s) -> DrumModel {
        using Sim = std::decay_t<decltype(s)>;
        DrumModel m;
        take_simulation(m, s);
        m.wall = std::get<CylinderWall>(s.walls);
        if constexpr (Sim::template kHasWall<EndCaps>) {
          m.capped = true;
          m.caps = std::get<EndCaps>(s.walls);
        }
        for (int a = 0; a < 3; ++a) m.periodic[a] = s.domain.periodic[a];
        return m;
      },
      sim);
}

std::size_t device_bytes(const DeviceSizing& z) {
  constexpr std::size_t kDoubles = 26, kWords = 12, kSortWords = 4, kCellWords = 3;
  return z.particles * (kDoubles * sizeof(double) + (kWords + kSortWords + z.list_columns) * sizeof(std::uint32_t)) +
         z.cells * kCellWords * sizeof(std::uint32_t);
}

std::size_t expected_list_columns(double reach, double d_min) {
  const double ratio = reach / d_min;
  // Centres within `reach` at number density 6 phi / (pi d_min^3): 8 phi (reach / d_min)^3, less the particle itself.
  const double within = std::max(0.0, 8.0 * 0.64 * ratio * ratio * ratio - 1.0);
  const auto longest = static_cast<std::size_t>(std::ceil(within));
  return longest + longest / 4 + 8;
}

DeviceSizing drum_sizing(const DrumModel& m, int replicas) {
  double d_min = std::numeric_limits<double>::infinity(), d_max = 0.0;
  for (double d : m.p.d) {
    d_min = std::min(d_min, d);
    d_max = std::max(d_max, d);
  }
  const double reach =
      std::visit([&](const auto& law) { return std::decay_t<decltype(law)>::range(d_max, d_max); }, m.law) + m.skin;
  const auto c = cell_counts(m, reach);
  DeviceSizing z;
  z.particles = m.p.size() * static_cast<std::size_t>(replicas);
  z.cells = static_cast<std::size_t>(c[0]) * c[1] * c[2] * static_cast<std::size_t>(replicas);
  z.list_columns = m.p.size() > 0 ? expected_list_columns(reach, d_min) : 0;
  return z;
}

}  // namespace granular::gpu
