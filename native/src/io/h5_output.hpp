// Output in the common HDF5 schema (docs/output_schema.md) that the native
// engine, the LAMMPS case and the YADE case all write. Frames are appended to
// datasets extendible along their first axis and the file is flushed after
// every append, so a run that stops early keeps everything written so far.
#pragma once
#include <hdf5.h>

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/particles.hpp"

namespace granular {

// Rows of every appendable dataset, by path ("frames/time", ...): what a
// checkpoint records so that a resumed run can cut the output back to it.
using RowCounts = std::map<std::string, std::uint64_t>;

class H5Output {
 public:
  // with_force: snapshots also carry each particle's contact force.
  // resume: continue the existing file from a checkpoint: every dataset the run
  // declares starts with the existing file's rows up to the checkpoint's
  // record (rows written after it are written again). They are copied into a
  // new file beside it (path + ".resuming"), which replaces it at
  // start_swmr(); a resume that fails before then leaves it as it was.
  H5Output(const std::string& path, int dim, std::int64_t n_particles, bool with_force = false,
           const RowCounts* resume = nullptr);
  ~H5Output();
  H5Output(const H5Output&) = delete;
  H5Output& operator=(const H5Output&) = delete;

  void attr(const std::string& name, const std::string& value);
  void attr(const std::string& name, double value);
  void attr(const std::string& name, std::int64_t value);
  void group_attr(const std::string& group, const std::string& name, const std::vector<std::string>& values);

  // One snapshot; particles are written in id order.
  template <int Dim>
  void frame(double time, long step, const ParticleStore<Dim>& p);

  void init_profile(const std::vector<double>& edges);
  void profile(double time, const std::vector<double>& small_fraction);

  // A group of datasets that grow together by one row per sample (e.g. the
  // big disk's trajectory); each column has a fixed row width. Returns the
  // handle that series() appends to.
  int init_series(const std::string& group, const std::vector<std::pair<std::string, int>>& columns);
  void series(int handle, const std::vector<std::vector<double>>& row);

  const std::string& path() const { return path_; }
  RowCounts rows() const;

  // From here on the file only grows by appended rows (no new groups, datasets
  // or attributes), in HDF5's single-writer/multiple-reader mode: its writes
  // are ordered so that the file on disk is consistent at every moment, and a
  // run killed at any point leaves a file that opens (readers: h5py's
  // swmr=True, as compare.reader does) and holds every row flushed.
  void start_swmr();

  // Rewrites the XDMF description beside the file (io/xdmf.hpp) for the
  // frames written so far. Returns false, with a warning on stderr, where it
  // cannot: the description is a convenience, the HDF5 file stays complete.
  bool write_xdmf() const noexcept;

 private:
  struct Appendable {
    std::string name;  // path in the file
    hid_t dset = -1;
    std::vector<hsize_t> row;  // shape of one row (without the leading axis)
    hid_t type = -1;
    hsize_t rows = 0;
  };
  Appendable make(hid_t group, const std::string& group_name, const char* name, hid_t type, std::vector<hsize_t> row);
  hid_t group(const std::string& name);  // created in the file being written
  std::vector<const Appendable*> all() const;
  void append(Appendable& a, const void* data);
  void append_rows(Appendable& a, const void* data, hsize_t m);
  void copy_rows(Appendable& a);  // resuming: the old file's rows up to the checkpoint
  void close_all();
  void commit_resume();           // resuming: the copy replaces the old file
  std::string resume_path() const { return path_ + ".resuming"; }
  void write_frame(double time, long step, const std::vector<std::int64_t>& id, const std::vector<std::int32_t>& sp,
                   const std::vector<double>& d, const std::vector<double>& x, const std::vector<double>& v,
                   const std::vector<double>& w);

  std::string path_;
  int dim_ = 3;
  std::int64_t n_ = 0;
  hid_t file_ = -1, frames_ = -1, profile_ = -1;
  hid_t old_ = -1;  // resuming: the file being continued, read-only until the copy replaces it
  Appendable f_time_, f_step_, f_id_, f_species_, f_diam_, f_pos_, f_vel_, f_ang_;
  Appendable p_time_, p_frac_, f_force_;
  bool with_force_ = false;
  bool resuming_ = false;
  bool swmr_ = false;
  RowCounts resume_rows_;       // resuming: rows of each dataset to carry over
  std::set<std::string> copied_;  // resuming: datasets carried over so far
  struct Series {
    hid_t group = -1;
    std::vector<Appendable> columns;
  };
  std::vector<Series> series_;
};

template <int Dim>
void H5Output::frame(double time, long step, const ParticleStore<Dim>& p) {
  const std::size_t n = p.size();
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[static_cast<std::size_t>(p.id[k])] = k;  // ids are 0..n-1
  constexpr int na = Space<Dim>::kAngDim;
  std::vector<std::int64_t> id(n);
  std::vector<std::int32_t> sp(n);
  std::vector<double> d(n), x(n * Dim), v(n * Dim), w(n * na);
  for (std::size_t q = 0; q < n; ++q) {
    const std::size_t k = order[q];
    id[q] = p.id[k];
    sp[q] = p.species[k];
    d[q] = p.d[k];
    for (int c = 0; c < Dim; ++c) {
      x[q * Dim + c] = p.x[k][c];
      v[q * Dim + c] = p.v[k][c];
    }
    for (int c = 0; c < na; ++c) w[q * na + c] = p.w[k][c];
  }
  if (with_force_) {
    std::vector<double> f(n * Dim);
    for (std::size_t q = 0; q < n; ++q)
      for (int c = 0; c < Dim; ++c) f[q * Dim + c] = p.f[order[q]][c];
    append(f_force_, f.data());
  }
  write_frame(time, step, id, sp, d, x, v, w);
}

}  // namespace granular
