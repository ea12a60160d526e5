#include "io/xdmf.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <locale>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace granular {

namespace {

// Text of an XML element or attribute value.
std::string xml_escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '&': r += "&amp;"; break;
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '"': r += "&quot;"; break;
      default: r += c;
    }
  }
  return r;
}

std::string join(const std::vector<std::int64_t>& v) {
  std::string r;
  for (std::size_t k = 0; k < v.size(); ++k) r += (k ? " " : "") + std::to_string(v[k]);
  return r;
}

// One /frames dataset as the writer declares it (io/h5_output.cpp): shape
// (F, row...), stored as `number` of `precision` bytes.
struct Column {
  const char* name;       // dataset name in /frames
  std::vector<std::int64_t> row;  // shape of one frame's row
  const char* number;     // XDMF NumberType: "Float" or "Int"
  int precision;          // bytes per value
};

// A HyperSlab DataItem: frame f of the dataset /frames/<c.name>. Its first
// child (Format XML, Dimensions "3 rank") holds the selection's start, stride
// and count, one row each, over the dataset's axes (frame, particle,
// component); its second child (Format HDF) is the whole dataset, named
// FILE:/frames/<name> with its shape (F, row...). The item's own Dimensions is
// the shape of what it selects: one row, without the frame axis.
void hyperslab(std::ostream& o, const std::string& indent, const std::string& file, std::int64_t frames,
               std::int64_t f, const Column& c) {
  const std::size_t rank = c.row.size() + 1;
  std::vector<std::int64_t> start{f}, stride(rank, 1), count{1}, shape{frames};
  for (std::int64_t r : c.row) {
    start.push_back(0);
    count.push_back(r);
    shape.push_back(r);
  }
  o << indent << "<DataItem ItemType=\"HyperSlab\" Type=\"HyperSlab\" Dimensions=\"" << join(c.row) << "\">\n"
    << indent << "  <DataItem Dimensions=\"3 " << rank << "\" NumberType=\"Int\" Format=\"XML\">" << join(start) << "  "
    << join(stride) << "  " << join(count) << "</DataItem>\n"
    << indent << "  <DataItem Dimensions=\"" << join(shape) << "\" NumberType=\"" << c.number << "\" Precision=\""
    << c.precision << "\" Format=\"HDF\">" << xml_escape(file) << ":/frames/" << c.name << "</DataItem>\n"
    << indent << "</DataItem>\n";
}

}  // namespace

std::string xdmf_path(const std::string& h5_path) {
  std::filesystem::path p(h5_path);
  p.replace_extension(".xdmf");
  if (p == std::filesystem::path(h5_path)) return h5_path + ".xdmf";
  return p.string();
}

std::string xdmf_document(const std::string& h5_path, const XdmfFrames& fr) {
  const std::string file = std::filesystem::path(h5_path).filename().string();  // relative to the XDMF file
  const std::int64_t n = fr.particles, nf = static_cast<std::int64_t>(fr.times.size()), d = fr.dim;
  // The /frames datasets shown, with their per-frame row shapes and stored
  // types (id int64, species int32, float64 otherwise).
  const Column position{"position", {n, d}, "Float", 8};
  struct Shown {
    Column column;
    const char* type;  // XDMF AttributeType
  };
  std::vector<Shown> attributes{
      {{"diameter", {n}, "Float", 8}, "Scalar"},
      {{"species", {n}, "Int", 4}, "Scalar"},
      {{"id", {n}, "Int", 8}, "Scalar"},
      {{"velocity", {n, d}, "Float", 8}, "Vector"},
      // 3D: the angular velocity vector; 2D: its z component alone.
      {{"angular_velocity", {n, d == 3 ? 3 : 1}, "Float", 8}, d == 3 ? "Vector" : "Scalar"},
  };
  if (fr.with_force) attributes.push_back({{"force", {n, d}, "Float", 8}, "Vector"});

  std::ostringstream o;
  o.imbue(std::locale::classic());
  o.precision(17);  // times round-trip exactly to the float64 of /frames/time
  o << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
    << "<!-- The snapshot frames of " << xml_escape(file) << " (schema granular-frames, " << nf << " frames of "
    << n << " particles in " << d << "D) as particles; every array is read from that file. -->\n"
    // Only XDMF 2 elements are used (HyperSlab DataItems included): what
    // ParaView's "XDMF Reader" reads.
    << "<Xdmf Version=\"2.0\">\n"
    << "  <Domain>\n"
    // A time series: one grid per frame, in frame order.
    << "    <Grid Name=\"Temporal\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::int64_t f = 0; f < nf; ++f) {
    o << "      <Grid Name=\"frame " << f << "\" GridType=\"Uniform\">\n"
      // The frame's simulation time, /frames/time[f].
      << "        <Time Value=\"" << fr.times[static_cast<std::size_t>(f)] << "\"/>\n"
      // N cells of one point each: the particles, with no connectivity.
      << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\"/>\n"
      // The points: particle centres, /frames/position[f] (z = 0 in 2D).
      << "        <Geometry GeometryType=\"" << (d == 3 ? "XYZ" : "XY") << "\">\n";
    hyperslab(o, "          ", file, nf, f, position);
    o << "        </Geometry>\n";
    // One value (or vector) per particle: /frames/<name>[f].
    for (const Shown& a : attributes) {
      o << "        <Attribute Name=\"" << a.column.name << "\" AttributeType=\"" << a.type << "\" Center=\"Node\">\n";
      hyperslab(o, "          ", file, nf, f, a.column);
      o << "        </Attribute>\n";
    }
    o << "      </Grid>\n";
  }
  o << "    </Grid>\n"
    << "  </Domain>\n"
    << "</Xdmf>\n";
  return o.str();
}

void write_xdmf(const std::string& h5_path, const XdmfFrames& frames) {
  const std::string path = xdmf_path(h5_path), tmp = path + ".tmp";
  const std::string text = xdmf_document(h5_path, frames);
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error(tmp + ": cannot create the XDMF description");
    f << text;
    f.close();
    if (!f) {
      std::remove(tmp.c_str());
      throw std::runtime_error(tmp + ": cannot write the XDMF description");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);  // atomic: readers see the old file or the new one
  if (ec) {
    std::remove(tmp.c_str());
    throw std::runtime_error(tmp + ": cannot rename it to " + path + ": " + ec.message());
  }
}

}  // namespace granular
