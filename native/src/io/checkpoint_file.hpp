// A checkpoint on disk: everything a run needs to continue exactly where it
// was. Written to PATH.tmp, synced, then renamed over PATH, so a checkpoint on
// disk is always a complete one (an interrupted write leaves the previous one).
// The columns are the particle store in storage order, raw (bit for bit), so a
// resumed run repeats the uninterrupted one exactly; engine/checkpoint.hpp maps
// a simulation to and from them.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "io/h5_output.hpp"  // RowCounts

namespace granular {

struct CheckpointData {
  std::string scene_json;      // the resolved scene the run was started with
  std::string engine_version;
  std::int64_t threads = 1;    // the thread count, which fixes the force summation order
  std::int64_t step = 0;       // steps done
  double time = 0.0;           // simulation time (accumulated exactly as the run does)
  std::int64_t seed = 0;       // particles.seed; no random numbers are drawn after set-up
  std::vector<std::int64_t> counters;  // the run loop's output counters
  RowCounts rows;                      // rows of every output dataset at this point
  std::map<std::string, std::vector<double>> reals;  // particle columns, flattened
  std::map<std::string, std::vector<std::int64_t>> ints;
};

// Atomic: PATH.tmp, fsync, rename. Throws std::runtime_error naming the file.
void write_checkpoint(const std::string& path, const CheckpointData& c);
// Throws std::runtime_error naming the file and what is missing or malformed.
CheckpointData read_checkpoint(const std::string& path);

// The checkpoint that belongs to an output file.
inline std::string checkpoint_path(const std::string& output) { return output + ".ckpt"; }

}  // namespace granular
