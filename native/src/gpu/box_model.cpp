#include "gpu/box_model.hpp"

#include <type_traits>

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

}  // namespace granular::gpu
