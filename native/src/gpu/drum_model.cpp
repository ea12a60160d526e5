#include "gpu/drum_model.hpp"

#include <type_traits>

namespace granular::gpu {

static_assert(std::is_same_v<VariantOf<DrumLaws>, DrumGpuLaw>,
              "the GPU drum's laws (gpu/drum_gpu.hpp) are the CPU drum's (engine/drum.hpp)");

DrumModel drum_model(const DrumSim& sim) {
  return std::visit(
      [](const auto& s) -> DrumModel {
        using Sim = std::decay_t<decltype(s)>;
        DrumModel m;
        m.law = s.law;
        m.wall = std::get<CylinderWall>(s.walls);
        if constexpr (Sim::template kHasWall<EndCaps>) {
          m.capped = true;
          m.caps = std::get<EndCaps>(s.walls);
        }
        for (int a = 0; a < 3; ++a) {
          m.lo[a] = s.domain.lo[a];
          m.hi[a] = s.domain.hi[a];
          m.periodic[a] = s.domain.periodic[a];
          m.gravity[a] = s.integrator.gravity[a];
        }
        m.dt = s.integrator.dt;
        m.skin = s.skin;
        m.time = s.time;
        m.step_count = s.step_count;
        m.p = s.p;
        return m;
      },
      sim);
}

}  // namespace granular::gpu
