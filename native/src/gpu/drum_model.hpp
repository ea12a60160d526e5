// A CPU drum simulation's step and state as the GPU path's DrumModel
// (gpu/drum_gpu.hpp): the GPU drum starts from the scene path and the state
// the CPU engine builds (engine/drum.cpp, make_drum).
#pragma once
#include "engine/drum.hpp"
#include "gpu/drum_gpu.hpp"

namespace granular::gpu {

// The model of a drum, with periodic ends or end caps.
DrumModel drum_model(const DrumSim& sim);

}  // namespace granular::gpu
