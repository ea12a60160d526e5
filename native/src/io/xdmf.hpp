// An XDMF description of the snapshot frames of an output file in the common
// schema (docs/output_schema.md), written beside it (OUT.h5 -> OUT.xdmf), so
// that ParaView (its "XDMF Reader") opens the frames as particles straight
// from the HDF5 file. The description holds no data of its own: every array is
// a hyperslab (one frame) of a /frames dataset, named by the HDF5 file's base
// name, so the two files can be moved together.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace granular {

// What the description covers: the first times.size() frames of /frames.
struct XdmfFrames {
  int dim = 3;                      // 3: XYZ positions; 2: XY positions
  std::int64_t particles = 0;       // N, the particles in every frame
  std::vector<double> times;        // /frames/time of each frame described
  bool with_force = false;          // /frames/force is written (shaken box)
};

// OUT.xdmf for the output file OUT.h5 (the extension replaced; appended when
// replacing it would name the output file itself).
std::string xdmf_path(const std::string& h5_path);

// The XDMF document (XDMF 2) for the output file h5_path: a temporal
// collection "Temporal" of one uniform grid per frame.
std::string xdmf_document(const std::string& h5_path, const XdmfFrames& frames);

// Writes xdmf_document() to xdmf_path(h5_path) through a temporary file
// (OUT.xdmf.tmp) renamed over it, so the file on disk is always a whole one.
// Throws std::runtime_error naming the file.
void write_xdmf(const std::string& h5_path, const XdmfFrames& frames);

}  // namespace granular
