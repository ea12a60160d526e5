// A drum run on the GPU path (docs/gpu.md): the CPU engine's run loop
// (engine/drum.cpp, run_drums), output, health checks and checkpoints, with
// the state stepped by a DrumStepper (gpu/drum_gpu.hpp) and brought into the
// simulations' stores only where the loop observes, checks or checkpoints.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "engine/drum.hpp"
#include "gpu/drum_gpu.hpp"
#include "scene/drum_scene.hpp"

namespace granular::gpu {

// Why the GPU engine does not run a scene, or empty where it does: the one
// place that says which scenes it runs. `kind` is scene.kind; drum is the
// scene where kind is "drum".
std::string unsupported_scene(const std::string& kind, const DrumScene* drum);

// Makes the stepper of one or several replicas (make_host_drum, make_cuda_drum).
using StepperFactory = std::unique_ptr<DrumStepper> (*)(const std::vector<DrumModel>&);

// The driver (engine/drum.hpp, DrumDriver) of the drums sims[0..K) (one scene,
// K seeds), stepped together as the replicas of one stepper from `make`.
// labels[r] names member r in the message of an instability when K > 1.
//
// Where the run loop asks for it, a member's state is downloaded into its
// simulation's store, in the order the stepper keeps (the simulation's after
// make_drum); nothing is downloaded between. Each step the stepper checks the
// move limit (Simulation::max_step_move); a step beyond it is reported by the
// CPU engine's own check (Simulation::report_unstable_step). The health check
// (engine/health.hpp) runs on the device as a screen (each replica's worst
// overlap and any non-finite value); where it finds one beyond the limit,
// engine/health.hpp's check_health runs on the downloaded state (a copy with
// a neighbour list of its own) and stops the run with its message. The
// Coulomb census is taken the same way, on a copy with its own list.
// Checkpoints hold the stepper's order and its neighbour list's reference
// positions, so a resumed run repeats the uninterrupted one bit for bit.
std::unique_ptr<DrumDriver> make_drum_driver(const DrumScene& s, std::vector<DrumSim*> sims, StepperFactory make,
                                             std::vector<std::string> labels = {});

// The key a GPU run's checkpoint carries (CheckpointData::ints), which the
// CPU engine's lack: a run resumes on the engine that wrote its checkpoint.
inline constexpr const char* kCheckpointKey = "gpu_path";

}  // namespace granular::gpu
