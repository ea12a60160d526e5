#include "io/h5_output.hpp"

#include "io/xdmf.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace granular {

namespace {
void check(herr_t e, const std::string& what, const std::string& path) {
  if (e < 0) throw std::runtime_error(path + ": HDF5 error while " + what);
}
}  // namespace

H5Output::H5Output(const std::string& path, int dim, std::int64_t n, bool with_force, const RowCounts* resume)
    : path_(path), dim_(dim), n_(n), with_force_(with_force), resuming_(resume != nullptr) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions below, not stderr dumps
  // The HDF5 1.10 format, which single-writer/multiple-reader mode needs (start_swmr()).
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_libver_bounds(fapl, H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  std::string create_at = path;
  if (resuming_) {
    // The file to resume may have been left by a writer that was killed: it
    // reads back every row flushed before the kill, but HDF5 cannot safely
    // write into it again (its record of allocated space may lag what the dead
    // writer allocated, and a reopened writer could hand the same bytes out
    // twice). So it is only read: the rows up to the checkpoint are copied
    // into a new file beside it (make()), which replaces it in one rename
    // once every dataset is copied (commit_resume()). Until then the output on
    // disk is untouched, whatever happens to this run.
    resume_rows_ = *resume;
    old_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, H5P_DEFAULT);
    if (old_ < 0) old_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);  // a file in the pre-1.10 format
    if (old_ < 0) {
      H5Pclose(fapl);
      throw std::runtime_error(path + ": cannot open the output file to resume it (missing or damaged)");
    }
    create_at = resume_path();
  }
  file_ = H5Fcreate(create_at.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  H5Pclose(fapl);
  if (file_ < 0) {
    if (old_ >= 0) H5Fclose(old_);
    throw std::runtime_error(create_at + ": cannot create the output file");
  }
  try {
    frames_ = group("frames");
    const hsize_t un = static_cast<hsize_t>(n), ud = static_cast<hsize_t>(dim);
    const hsize_t ua = dim == 3 ? 3 : 1;
    f_time_ = make(frames_, "frames", "time", H5T_NATIVE_DOUBLE, {});
    f_step_ = make(frames_, "frames", "step", H5T_NATIVE_INT64, {});
    f_id_ = make(frames_, "frames", "id", H5T_NATIVE_INT64, {un});
    f_species_ = make(frames_, "frames", "species", H5T_NATIVE_INT32, {un});
    f_diam_ = make(frames_, "frames", "diameter", H5T_NATIVE_DOUBLE, {un});
    f_pos_ = make(frames_, "frames", "position", H5T_NATIVE_DOUBLE, {un, ud});
    f_vel_ = make(frames_, "frames", "velocity", H5T_NATIVE_DOUBLE, {un, ud});
    f_ang_ = make(frames_, "frames", "angular_velocity", H5T_NATIVE_DOUBLE, {un, ua});
    if (with_force) f_force_ = make(frames_, "frames", "force", H5T_NATIVE_DOUBLE, {un, ud});
    attr("schema", std::string("granular-frames"));
    attr("schema_version", std::int64_t{1});
    attr("dim", std::int64_t{dim});
  } catch (...) {
    close_all();  // no destructor runs for a constructor that throws
    throw;
  }
}

void H5Output::start_swmr() {
  if (swmr_) return;
  if (resuming_) commit_resume();
  check(H5Fstart_swmr_write(file_), "switching to single-writer/multiple-reader mode", path_);
  swmr_ = true;
}

void H5Output::commit_resume() {
  for (const auto& [name, rows] : resume_rows_)
    if (!copied_.count(name))
      throw std::runtime_error(path_ + ": the checkpoint records dataset " + name +
                               ", which this run does not write; cannot resume into this file");
  check(H5Fflush(file_, H5F_SCOPE_GLOBAL), "flushing the resumed copy", path_);
  H5Fclose(old_);
  old_ = -1;
  std::error_code ec;
  std::filesystem::rename(resume_path(), path_, ec);  // the open handle follows the file
  if (ec) throw std::runtime_error(resume_path() + ": cannot replace " + path_ + " with it: " + ec.message());
  resuming_ = false;
}

hid_t H5Output::group(const std::string& name) {
  if (swmr_) throw std::logic_error(path_ + ": group " + name + " declared after start_swmr()");
  hid_t g = H5Gcreate2(file_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) throw std::runtime_error(path_ + ": cannot create group " + name);
  return g;
}

std::vector<const H5Output::Appendable*> H5Output::all() const {
  std::vector<const Appendable*> v;
  for (const Appendable* a : {&f_time_, &f_step_, &f_id_, &f_species_, &f_diam_, &f_pos_, &f_vel_, &f_ang_,
                              &f_force_, &p_time_, &p_frac_})
    if (a->dset >= 0) v.push_back(a);
  for (const auto& g : series_)
    for (const auto& a : g.columns) v.push_back(&a);
  return v;
}

RowCounts H5Output::rows() const {
  RowCounts r;
  for (const Appendable* a : all()) r[a->name] = a->rows;
  return r;
}

H5Output::~H5Output() { close_all(); }

void H5Output::close_all() {
  for (Appendable* a : {&f_time_, &f_step_, &f_id_, &f_species_, &f_diam_, &f_pos_, &f_vel_, &f_ang_, &p_time_,
                        &p_frac_, &f_force_})
    if (a->dset >= 0) H5Dclose(a->dset);
  for (auto& g : series_) {
    for (auto& a : g.columns)
      if (a.dset >= 0) H5Dclose(a.dset);
    if (g.group >= 0) H5Gclose(g.group);
  }
  if (profile_ >= 0) H5Gclose(profile_);
  if (frames_ >= 0) H5Gclose(frames_);
  if (file_ >= 0) H5Fclose(file_);
  f_time_.dset = f_step_.dset = f_id_.dset = f_species_.dset = f_diam_.dset = f_pos_.dset = f_vel_.dset = -1;
  f_ang_.dset = p_time_.dset = p_frac_.dset = f_force_.dset = -1;
  series_.clear();
  profile_ = frames_ = file_ = -1;
  if (old_ >= 0) {  // a resume that failed before its copy replaced the output: the output stays as it was
    H5Fclose(old_);
    std::error_code ec;
    std::filesystem::remove(resume_path(), ec);
    old_ = -1;
  }
}

H5Output::Appendable H5Output::make(hid_t group, const std::string& group_name, const char* name, hid_t type,
                                    std::vector<hsize_t> row) {
  const std::string full = group_name + "/" + name;
  std::vector<hsize_t> dims{0}, maxd{H5S_UNLIMITED}, chunk{1};
  for (hsize_t r : row) {
    dims.push_back(r);
    maxd.push_back(r);
    chunk.push_back(r);
  }
  if (row.empty()) chunk[0] = 256;
  hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxd.data());
  hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(plist, static_cast<int>(chunk.size()), chunk.data());
  hid_t d = H5Dcreate2(group, name, type, space, H5P_DEFAULT, plist, H5P_DEFAULT);
  H5Pclose(plist);
  H5Sclose(space);
  if (d < 0) throw std::runtime_error(path_ + ": cannot create dataset " + full);
  Appendable a{full, d, row, type, 0};
  if (resuming_) {
    try {
      copy_rows(a);
    } catch (...) {
      H5Dclose(d);
      throw;
    }
  }
  return a;
}

void H5Output::copy_rows(Appendable& a) {
  const auto it = resume_rows_.find(a.name);
  if (it == resume_rows_.end()) throw std::runtime_error(path_ + ": the checkpoint has no record of dataset " + a.name);
  const hsize_t n = it->second;
  hid_t src = H5Dopen2(old_, a.name.c_str(), H5P_DEFAULT);
  if (src < 0) throw std::runtime_error(path_ + ": dataset " + a.name + " is missing; cannot resume into this file");
  hid_t space = H5Dget_space(src);
  const int nd = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> have(static_cast<std::size_t>(std::max(nd, 0)));
  if (nd > 0) H5Sget_simple_extent_dims(space, have.data(), nullptr);
  H5Sclose(space);
  const bool same_rows = nd == static_cast<int>(a.row.size() + 1) && std::equal(a.row.begin(), a.row.end(), have.begin() + 1);
  if (!same_rows || have[0] < n) {
    H5Dclose(src);
    throw std::runtime_error(path_ + ": dataset " + a.name +
                             (same_rows ? " holds fewer rows than the checkpoint recorded" : " has rows of another shape"));
  }
  // In blocks of about 8 MB, through the new file's own append path.
  std::size_t row_bytes = H5Tget_size(a.type);
  for (hsize_t r : a.row) row_bytes *= r;
  const hsize_t block = std::max<hsize_t>(1, (8u << 20) / row_bytes);
  std::vector<unsigned char> buf(static_cast<std::size_t>(std::min(block, std::max<hsize_t>(n, 1))) * row_bytes);
  for (hsize_t r0 = 0; r0 < n; r0 += block) {
    const hsize_t m = std::min(block, n - r0);
    std::vector<hsize_t> start{r0}, count{m};
    for (hsize_t r : a.row) {
      start.push_back(0);
      count.push_back(r);
    }
    hid_t fspace = H5Dget_space(src);
    H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
    hid_t mspace = H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr);
    const herr_t e = H5Dread(src, a.type, mspace, fspace, H5P_DEFAULT, buf.data());
    H5Sclose(mspace);
    H5Sclose(fspace);
    if (e < 0) {
      H5Dclose(src);
      throw std::runtime_error(path_ + ": cannot read rows of " + a.name + " before the checkpoint (damaged file)");
    }
    append_rows(a, buf.data(), m);
  }
  H5Dclose(src);
  copied_.insert(a.name);
}

void H5Output::append(Appendable& a, const void* data) { append_rows(a, data, 1); }

void H5Output::append_rows(Appendable& a, const void* data, hsize_t m) {
  std::vector<hsize_t> dims{a.rows + m}, start{a.rows}, count{m};
  for (hsize_t r : a.row) {
    dims.push_back(r);
    start.push_back(0);
    count.push_back(r);
  }
  check(H5Dset_extent(a.dset, dims.data()), "extending a dataset", path_);
  hid_t fspace = H5Dget_space(a.dset);
  H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  hid_t mspace = H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr);
  const herr_t e = H5Dwrite(a.dset, a.type, mspace, fspace, H5P_DEFAULT, data);
  H5Sclose(mspace);
  H5Sclose(fspace);
  check(e, "writing", path_);
  a.rows += m;
}

void H5Output::write_frame(double time, long step, const std::vector<std::int64_t>& id,
                           const std::vector<std::int32_t>& sp, const std::vector<double>& d,
                           const std::vector<double>& x, const std::vector<double>& v, const std::vector<double>& w) {
  const std::int64_t st = step;
  append(f_time_, &time);
  append(f_step_, &st);
  append(f_id_, id.data());
  append(f_species_, sp.data());
  append(f_diam_, d.data());
  append(f_pos_, x.data());
  append(f_vel_, v.data());
  append(f_ang_, w.data());
  check(H5Fflush(file_, H5F_SCOPE_GLOBAL), "flushing", path_);
}

bool H5Output::write_xdmf() const noexcept {
  try {
    // The frames every /frames dataset holds (all hold the same number
    // between two frames), and their times read back from /frames/time.
    hsize_t nf = f_time_.rows;
    for (const Appendable* a : {&f_step_, &f_id_, &f_species_, &f_diam_, &f_pos_, &f_vel_, &f_ang_, &f_force_})
      if (a->dset >= 0) nf = std::min(nf, a->rows);
    XdmfFrames fr;
    fr.dim = dim_;
    fr.particles = n_;
    fr.with_force = with_force_;
    fr.times.resize(static_cast<std::size_t>(nf));
    if (nf > 0) {
      const hsize_t start = 0;
      hid_t fspace = H5Dget_space(f_time_.dset);
      H5Sselect_hyperslab(fspace, H5S_SELECT_SET, &start, nullptr, &nf, nullptr);
      hid_t mspace = H5Screate_simple(1, &nf, nullptr);
      const herr_t e = H5Dread(f_time_.dset, H5T_NATIVE_DOUBLE, mspace, fspace, H5P_DEFAULT, fr.times.data());
      H5Sclose(mspace);
      H5Sclose(fspace);
      check(e, "reading frames/time back", path_);
    }
    granular::write_xdmf(path_, fr);
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "warning: no XDMF description of %s: %s\n", path_.c_str(), e.what());
  } catch (...) {
    std::fprintf(stderr, "warning: no XDMF description of %s\n", path_.c_str());
  }
  return false;
}

void H5Output::init_profile(const std::vector<double>& edges) {
  profile_ = group("profile");
  const hsize_t ne = edges.size();
  {
    hid_t space = H5Screate_simple(1, &ne, nullptr);
    hid_t ds = H5Dcreate2(profile_, "edges", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const herr_t e = ds < 0 ? ds : H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, edges.data());
    if (ds >= 0) H5Dclose(ds);
    H5Sclose(space);
    check(e, "writing profile/edges", path_);
  }
  p_time_ = make(profile_, "profile", "time", H5T_NATIVE_DOUBLE, {});
  p_frac_ = make(profile_, "profile", "small_fraction", H5T_NATIVE_DOUBLE, {ne - 1});
  group_attr("profile", "axis", {"y"});
  group_attr("profile", "weighting", {"volume"});
}

void H5Output::profile(double time, const std::vector<double>& frac) {
  append(p_time_, &time);
  append(p_frac_, frac.data());
  check(H5Fflush(file_, H5F_SCOPE_GLOBAL), "flushing", path_);
}

int H5Output::init_series(const std::string& group, const std::vector<std::pair<std::string, int>>& columns) {
  Series g;
  g.group = this->group(group);
  for (const auto& [name, width] : columns) {
    std::vector<hsize_t> row;
    if (width > 1) row.push_back(static_cast<hsize_t>(width));
    g.columns.push_back(make(g.group, group, name.c_str(), H5T_NATIVE_DOUBLE, row));
  }
  series_.push_back(std::move(g));
  return static_cast<int>(series_.size()) - 1;
}

void H5Output::series(int handle, const std::vector<std::vector<double>>& row) {
  auto& cols = series_.at(static_cast<std::size_t>(handle)).columns;
  for (std::size_t k = 0; k < cols.size(); ++k) append(cols[k], row[k].data());
  check(H5Fflush(file_, H5F_SCOPE_GLOBAL), "flushing", path_);
}

namespace {
void write_string_attr(hid_t obj, const std::string& name, const std::vector<std::string>& values, bool scalar) {
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  std::vector<const char*> ptrs;
  for (const auto& v : values) ptrs.push_back(v.c_str());
  const hsize_t n = values.size();
  hid_t space = scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr);
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  hid_t a = H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(a, type, ptrs.data());
  H5Aclose(a);
  H5Sclose(space);
  H5Tclose(type);
}

template <class T>
void write_scalar_attr(hid_t obj, const std::string& name, hid_t type, T value) {
  hid_t space = H5Screate(H5S_SCALAR);
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  hid_t a = H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(a, type, &value);
  H5Aclose(a);
  H5Sclose(space);
}
}  // namespace

void H5Output::attr(const std::string& name, const std::string& value) {
  if (swmr_) throw std::logic_error(path_ + ": attribute " + name + " written after start_swmr()");
  write_string_attr(file_, name, {value}, true);
}
void H5Output::attr(const std::string& name, double value) {
  if (swmr_) throw std::logic_error(path_ + ": attribute " + name + " written after start_swmr()");
  write_scalar_attr(file_, name, H5T_NATIVE_DOUBLE, value);
}
void H5Output::attr(const std::string& name, std::int64_t value) {
  if (swmr_) throw std::logic_error(path_ + ": attribute " + name + " written after start_swmr()");
  write_scalar_attr(file_, name, H5T_NATIVE_INT64, value);
}
void H5Output::group_attr(const std::string& group, const std::string& name, const std::vector<std::string>& values) {
  if (swmr_) throw std::logic_error(path_ + ": attribute " + name + " written after start_swmr()");
  hid_t g = H5Gopen2(file_, group.c_str(), H5P_DEFAULT);
  write_string_attr(g, name, values, values.size() == 1);
  H5Gclose(g);
}

}  // namespace granular
