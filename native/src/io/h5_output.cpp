#include "io/h5_output.hpp"

#include <iostream>
#include <stdexcept>

namespace granular {

namespace {
void check(herr_t e, const std::string& what, const std::string& path) {
  if (e < 0) throw std::runtime_error(path + ": HDF5 error while " + what);
}
}  // namespace

H5Output::H5Output(const std::string& path, int dim, std::int64_t n, bool with_force, const RowCounts* resume)
    : path_(path), with_force_(with_force), resuming_(resume != nullptr) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions below, not stderr dumps
  // The HDF5 1.10 format, which single-writer/multiple-reader mode needs (start_swmr()).
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_libver_bounds(fapl, H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  if (resuming_) {
    resume_rows_ = *resume;
    // A writer that was killed leaves the file marked "open for writing"; clear
    // the mark as the h5clear tool does (its file-access property).
    hbool_t clear = true;
    H5Pset(fapl, "clear_status_flags", &clear);
    file_ = H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl);
    H5Pclose(fapl);
    if (file_ < 0) throw std::runtime_error(path + ": cannot open the output file to resume it (missing or damaged)");
  } else {
    file_ = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
    H5Pclose(fapl);
    if (file_ < 0) throw std::runtime_error(path + ": cannot create the output file");
  }
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
}

void H5Output::start_swmr() {
  if (swmr_) return;
  // A file resumed from an earlier version of this program may predate the
  // 1.10 format (superblock version < 3), which cannot be switched: it goes on
  // in the ordinary mode, with the risk stated.
  H5F_info2_t info;
  check(H5Fget_info2(file_, &info), "reading the file's format version", path_);
  if (info.super.version < 3) {
    std::cerr << "note: " << path_ << " was created in an older HDF5 format that single-writer/multiple-reader "
              << "mode cannot use; it is continued without it (a run killed with SIGKILL may leave it "
              << "unreadable; checkpoints are unaffected)\n";
    return;
  }
  check(H5Fstart_swmr_write(file_), "switching to single-writer/multiple-reader mode", path_);
  swmr_ = true;
}

hid_t H5Output::group(const std::string& name) {
  if (swmr_) throw std::logic_error(path_ + ": group " + name + " declared after start_swmr()");
  hid_t g = resuming_ && H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0
                ? H5Gopen2(file_, name.c_str(), H5P_DEFAULT)
                : H5Gcreate2(file_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) throw std::runtime_error(path_ + ": cannot create or open group " + name);
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

H5Output::~H5Output() {
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
  if (resuming_) {
    // Cut back to the checkpoint's rows: anything written after it is written again.
    const auto it = resume_rows_.find(full);
    if (it == resume_rows_.end())
      throw std::runtime_error(path_ + ": the checkpoint has no record of dataset " + full);
    hid_t d = H5Dopen2(group, name, H5P_DEFAULT);
    if (d < 0) throw std::runtime_error(path_ + ": dataset " + full + " is missing; cannot resume into this file");
    hid_t space = H5Dget_space(d);
    std::vector<hsize_t> have(dims.size());
    const int nd = H5Sget_simple_extent_ndims(space);
    if (nd == static_cast<int>(dims.size())) H5Sget_simple_extent_dims(space, have.data(), nullptr);
    H5Sclose(space);
    if (nd != static_cast<int>(dims.size()) || have[0] < it->second)
      throw std::runtime_error(path_ + ": dataset " + full + " holds fewer rows than the checkpoint recorded");
    dims[0] = it->second;
    check(H5Dset_extent(d, dims.data()), "cutting " + full + " back to the checkpoint", path_);
    return {full, d, row, type, it->second};
  }
  if (row.empty()) chunk[0] = 256;
  hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxd.data());
  hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(plist, static_cast<int>(chunk.size()), chunk.data());
  hid_t d = H5Dcreate2(group, name, type, space, H5P_DEFAULT, plist, H5P_DEFAULT);
  H5Pclose(plist);
  H5Sclose(space);
  if (d < 0) throw std::runtime_error(path_ + ": cannot create dataset " + full);
  return {full, d, row, type, 0};
}

void H5Output::append(Appendable& a, const void* data) {
  std::vector<hsize_t> dims{a.rows + 1}, start{a.rows}, count{1};
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
  ++a.rows;
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

void H5Output::init_profile(const std::vector<double>& edges) {
  const bool exists = resuming_ && H5Lexists(file_, "profile", H5P_DEFAULT) > 0;
  profile_ = group("profile");
  const hsize_t ne = edges.size();
  if (!exists) {
    hid_t space = H5Screate_simple(1, &ne, nullptr);
    hid_t ds = H5Dcreate2(profile_, "edges", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, edges.data());
    H5Dclose(ds);
    H5Sclose(space);
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
