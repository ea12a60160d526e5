#include "io/checkpoint_file.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace granular {

namespace {

constexpr const char* kFormat = "granular-checkpoint";
constexpr std::int64_t kFormatVersion = 1;

struct Handle {  // closes an HDF5 object on scope exit
  hid_t id;
  herr_t (*close)(hid_t);
  ~Handle() {
    if (id >= 0) close(id);
  }
};

void put_string(hid_t obj, const char* name, const std::string& v) {
  Handle type{H5Tcopy(H5T_C_S1), H5Tclose};
  H5Tset_size(type.id, H5T_VARIABLE);
  H5Tset_cset(type.id, H5T_CSET_UTF8);
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  Handle a{H5Acreate2(obj, name, type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  const char* p = v.c_str();
  if (a.id < 0 || H5Awrite(a.id, type.id, &p) < 0) throw std::runtime_error(std::string("writing attribute ") + name);
}

template <class T>
void put_scalar(hid_t obj, const char* name, hid_t type, T v) {
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  Handle a{H5Acreate2(obj, name, type, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  if (a.id < 0 || H5Awrite(a.id, type, &v) < 0) throw std::runtime_error(std::string("writing attribute ") + name);
}

std::string get_string(hid_t obj, const char* name) {
  Handle a{H5Aopen(obj, name, H5P_DEFAULT), H5Aclose};
  if (a.id < 0) throw std::runtime_error(std::string("missing attribute ") + name);
  Handle type{H5Aget_type(a.id), H5Tclose};
  if (H5Tget_class(type.id) != H5T_STRING || !H5Tis_variable_str(type.id))
    throw std::runtime_error(std::string("attribute ") + name + " is not a string");
  Handle mem{H5Tcopy(H5T_C_S1), H5Tclose};
  H5Tset_size(mem.id, H5T_VARIABLE);
  H5Tset_cset(mem.id, H5T_CSET_UTF8);
  char* p = nullptr;
  if (H5Aread(a.id, mem.id, &p) < 0 || !p) throw std::runtime_error(std::string("reading attribute ") + name);
  std::string s(p);
  H5free_memory(p);
  return s;
}

template <class T>
T get_scalar(hid_t obj, const char* name, hid_t type) {
  Handle a{H5Aopen(obj, name, H5P_DEFAULT), H5Aclose};
  T v{};
  if (a.id < 0 || H5Aread(a.id, type, &v) < 0) throw std::runtime_error(std::string("missing attribute ") + name);
  return v;
}

template <class T>
void put_column(hid_t g, const std::string& name, hid_t type, const std::vector<T>& v) {
  const hsize_t n = v.size();
  Handle space{H5Screate_simple(1, &n, nullptr), H5Sclose};
  Handle d{H5Dcreate2(g, name.c_str(), type, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose};
  if (d.id < 0 || (n > 0 && H5Dwrite(d.id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0))
    throw std::runtime_error("writing column " + name);
}

template <class T>
std::vector<T> get_column(hid_t g, const std::string& name, hid_t type) {
  Handle d{H5Dopen2(g, name.c_str(), H5P_DEFAULT), H5Dclose};
  if (d.id < 0) throw std::runtime_error("missing column " + name);
  Handle space{H5Dget_space(d.id), H5Sclose};
  if (H5Sget_simple_extent_ndims(space.id) != 1) throw std::runtime_error("column " + name + " is not 1-D");
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space.id, &n, nullptr);
  std::vector<T> v(n);
  if (n > 0 && H5Dread(d.id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw std::runtime_error("reading column " + name);
  return v;
}

herr_t collect_name(hid_t, const char* name, const H5L_info_t*, void* out) {
  static_cast<std::vector<std::string>*>(out)->push_back(name);
  return 0;
}

}  // namespace

void write_checkpoint(const std::string& path, const CheckpointData& c) {
  const std::string tmp = path + ".tmp";
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  try {
    {
      Handle f{H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose};
      if (f.id < 0) throw std::runtime_error("cannot create the file");
      put_string(f.id, "format", kFormat);
      put_scalar(f.id, "format_version", H5T_NATIVE_INT64, kFormatVersion);
      put_string(f.id, "scene_json", c.scene_json);
      put_string(f.id, "engine_version", c.engine_version);
      put_scalar(f.id, "threads", H5T_NATIVE_INT64, c.threads);
      put_scalar(f.id, "step", H5T_NATIVE_INT64, c.step);
      put_scalar(f.id, "time", H5T_NATIVE_DOUBLE, c.time);
      put_scalar(f.id, "seed", H5T_NATIVE_INT64, c.seed);
      put_string(f.id, "counters", nlohmann::json(c.counters).dump());
      put_string(f.id, "output_rows", nlohmann::json(c.rows).dump());
      Handle g{H5Gcreate2(f.id, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
      for (const auto& [name, v] : c.reals) put_column(g.id, name, H5T_NATIVE_DOUBLE, v);
      for (const auto& [name, v] : c.ints) put_column(g.id, name, H5T_NATIVE_INT64, v);
    }
    // On disk before it replaces the previous checkpoint.
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    if (fd < 0 || ::fsync(fd) != 0) {
      if (fd >= 0) ::close(fd);
      throw std::runtime_error("cannot sync the file");
    }
    ::close(fd);
    if (std::rename(tmp.c_str(), path.c_str()) != 0) throw std::runtime_error("cannot rename " + tmp + " to it");
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": writing the checkpoint failed: " + e.what());
  }
}

CheckpointData read_checkpoint(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  CheckpointData c;
  try {
    Handle f{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
    if (f.id < 0) throw std::runtime_error("cannot open it as HDF5");
    if (get_string(f.id, "format") != kFormat) throw std::runtime_error("not a granular checkpoint");
    const auto version = get_scalar<std::int64_t>(f.id, "format_version", H5T_NATIVE_INT64);
    if (version != kFormatVersion)
      throw std::runtime_error("format_version " + std::to_string(version) + ", this engine reads " +
                               std::to_string(kFormatVersion));
    c.scene_json = get_string(f.id, "scene_json");
    c.engine_version = get_string(f.id, "engine_version");
    c.threads = get_scalar<std::int64_t>(f.id, "threads", H5T_NATIVE_INT64);
    c.step = get_scalar<std::int64_t>(f.id, "step", H5T_NATIVE_INT64);
    c.time = get_scalar<double>(f.id, "time", H5T_NATIVE_DOUBLE);
    c.seed = get_scalar<std::int64_t>(f.id, "seed", H5T_NATIVE_INT64);
    c.counters = nlohmann::json::parse(get_string(f.id, "counters")).get<std::vector<std::int64_t>>();
    c.rows = nlohmann::json::parse(get_string(f.id, "output_rows")).get<RowCounts>();
    Handle g{H5Gopen2(f.id, "particles", H5P_DEFAULT), H5Gclose};
    if (g.id < 0) throw std::runtime_error("missing group particles");
    std::vector<std::string> names;
    hsize_t idx = 0;
    H5Literate(g.id, H5_INDEX_NAME, H5_ITER_INC, &idx, collect_name, &names);
    for (const auto& name : names) {
      Handle d{H5Dopen2(g.id, name.c_str(), H5P_DEFAULT), H5Dclose};
      Handle type{H5Dget_type(d.id), H5Tclose};
      if (H5Tget_class(type.id) == H5T_INTEGER)
        c.ints[name] = get_column<std::int64_t>(g.id, name, H5T_NATIVE_INT64);
      else
        c.reals[name] = get_column<double>(g.id, name, H5T_NATIVE_DOUBLE);
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": damaged checkpoint: " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": damaged checkpoint: " + e.what());
  }
  return c;
}

}  // namespace granular
