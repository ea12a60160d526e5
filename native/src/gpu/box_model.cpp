#include "gpu/box_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>
#include <variant>
#include <vector>

#include "gpu/drum_gpu.hpp"  // DeviceSizing

namespace granular::gpu {

static_assert(std::is_same_v<VariantOf<BoxLaws>, BoxGpuLaw>,
              "the GPU box's laws (gpu/box_gpu.hpp) are the CPU box's (engine/box.hpp)");

namespace {

template <class Integrator>
struct IsGear : std::false_type {};
template <int Dim, class Motion>
struct IsGear<Gear5<Dim, Motion>> : std::true_type {};

}  // namespace

BoxModel box_model(const BoxSim& sim) {
  return std::visit(
      [](const auto& s) -> BoxModel {
        using Sim = std::decay_t<decltype(s)>;
        using Integrator = std::decay_t<decltype(s.integrator)>;
        BoxModel m;
        take_simulation(m, s);
        if constexpr (IsGear<Integrator>::value) {
          m.integrator = BoxIntegrator::gear;
          m.gear_c0 = s.integrator.c0;
        } else {
          m.integrator = BoxIntegrator::leapfrog;
        }
        m.exclude_species = s.exclude_species;
        if constexpr (Sim::template kHasWall<FlatBoxWalls>) {
          m.walls = BoxWalls::smooth;
          m.flat = std::get<FlatBoxWalls>(s.walls);
          m.shaker = m.flat.shaker;
        } else {
          m.shaker = s.integrator.motion;
        }
        return m;
      },
      sim);
}

DeviceSizing box_sizing(const std::vector<BoxModel>& ms) {
  DeviceSizing z;
  std::size_t columns = 0;
  for (const BoxModel& m : ms) {
    double d_min = std::numeric_limits<double>::infinity(), d_max = 0.0;
    for (double d : m.p.d) {
      d_min = std::min(d_min, d);
      d_max = std::max(d_max, d);
    }
    if (m.p.size() == 0) continue;
    const double reach =
        std::visit([&](const auto& law) { return std::decay_t<decltype(law)>::range(d_max, d_max); }, m.law) + m.skin;
    const auto c = cell_counts(m.lo, m.hi, std::array<bool, 2>{false, false}, reach);
    z.particles += m.p.size();
    z.cells += static_cast<std::size_t>(c[0]) * static_cast<std::size_t>(c[1]);
    // Centres within `reach` in a hexagonal packing of the smallest disks
    // (area fraction 0.91), less the particle itself, with the stepper's margin.
    const double ratio = reach / d_min;
    const auto within = static_cast<std::size_t>(std::ceil(std::max(0.0, 4.0 * 0.91 * ratio * ratio - 1.0)));
    columns = std::max(columns, within + within / 4 + 8);
  }
  // The box keeps 15 doubles a particle (2D) and the spare column (3), the
  // anchors and Gear's columns 15 more: 7 beyond device_bytes' 26, counted as
  // 14 four-byte words.
  z.list_columns = columns + 14;
  return z;
}

}  // namespace granular::gpu
