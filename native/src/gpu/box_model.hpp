// A CPU box simulation's step and state as the GPU path's BoxModel
// (gpu/box_gpu.hpp): the GPU box starts from the scene path and the state the
// CPU engine builds (engine/box.cpp, make_box).
#pragma once
#include "engine/box.hpp"
#include "gpu/box_gpu.hpp"

namespace granular::gpu {

// The model of a box, with walls of particles or smooth walls.
BoxModel box_model(const BoxSim& sim);

}  // namespace granular::gpu
