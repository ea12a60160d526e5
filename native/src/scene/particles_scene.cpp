#include "scene/particles_scene.hpp"

#include <hdf5.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include "contact/rapaport.hpp"
#include "contact/laws.hpp"
#include "scene/law_mapping.hpp"
#include "scene/step_rule.hpp"

namespace granular {

long ParticlesScene::steps_per(double time) const { return std::lround(time / dt); }

namespace {

// Only the required keys: reading it lists every key a particles scene has
// (besides the other two sources of the spheres and the walls: kOptional).
constexpr const char* kMinimalParticles = R"(
[scene]
kind = "particles"
name = "minimal"
[particles]
list = [{x = 0.0, y = 0.0, z = 0.0, d = 1.0, species = 0}]
[friction]
gamma_s_bb = 1.0
gamma_s_ss = 1.0
gamma_s_bw = 1.0
gamma_s_sw = 1.0
[run]
duration = 1.0
)";
const char* const kOptional[] = {"particles.csv", "particles.h5", "particles.frame", "wall"};

// A sphere's columns, in the order of particles.list's tables and the CSV
// header; the first three velocities and spins default to 0.
constexpr int kColumns = 11;
const char* const kColumn[kColumns] = {"x", "y", "z", "vx", "vy", "vz", "wx", "wy", "wz", "d", "species"};
bool required(int c) { return c < 3 || c >= 9; }
int column_of(const std::string& name) {
  for (int c = 0; c < kColumns; ++c)
    if (name == kColumn[c]) return c;
  return -1;
}
std::string column_list() {
  std::string s;
  for (int c = 0; c < kColumns; ++c) s += (c ? ", " : "") + std::string(kColumn[c]);
  return s;
}
std::string unknown_column(const std::string& name) {
  const std::string guess = did_you_mean(name, std::vector<std::string>(kColumn, kColumn + kColumns));
  return "unknown column \"" + name + "\"" + (guess.empty() ? "" : "; did you mean \"" + guess + "\"?") +
         " (allowed: " + column_list() + ")";
}

// The spheres as read, one row of columns each, and how a message names each
// row ("row 2 (line 9)", "spheres.csv line 4", "particle id 17").
struct Rows {
  std::string key;  // particles.list, particles.csv or particles.h5
  std::vector<std::array<double, kColumns>> values;
  std::vector<std::string> label;
};

std::string vec_text(const Eigen::Vector3d& v) {
  return "(" + number_text(v.x()) + ", " + number_text(v.y()) + ", " + number_text(v.z()) + ")";
}

// The path of a file named in the scene, relative to the scene file.
std::filesystem::path beside(const SceneFile& f, const std::string& name) {
  const std::filesystem::path p(name);
  if (p.is_absolute()) return p;
  return std::filesystem::path(f.path()).parent_path() / p;
}

Rows read_list(SceneFile& f) {
  Rows r{"particles.list", {}, {}};
  const toml::array& list = f.array(r.key);
  long row = 0;
  for (const toml::node& el : list) {
    ++row;
    const std::string label =
        "row " + std::to_string(row) + " (line " + std::to_string(el.source().begin.line) + ")";
    const toml::table* t = el.as_table();
    if (!t) f.fail(r.key, label + ": must be an inline table {x = ..., y = ..., z = ..., d = ..., species = ...}");
    std::array<double, kColumns> v{};
    std::array<bool, kColumns> seen{};
    for (const auto& [k, node] : *t) {
      const std::string name(k.str());
      const int c = column_of(name);
      if (c < 0) f.fail(r.key, label + ": " + unknown_column(name));
      const auto num = node.value<double>();
      if (!num || !(node.is_floating_point() || node.is_integer()))
        f.fail(r.key, label + ": " + name + " must be a number");
      if (c == 10 && !node.is_integer()) f.fail(r.key, label + ": species must be the integer 0 (small) or 1 (big)");
      v[c] = *num;
      seen[c] = true;
    }
    for (int c = 0; c < kColumns; ++c)
      if (required(c) && !seen[c]) f.fail(r.key, label + ": " + kColumn[c] + " missing (required)");
    r.values.push_back(v);
    r.label.push_back(label);
  }
  return r;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) {
    const auto a = field.find_first_not_of(" \t\r"), b = field.find_last_not_of(" \t\r");
    out.push_back(a == std::string::npos ? std::string() : field.substr(a, b - a + 1));
  }
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

Rows read_csv(SceneFile& f) {
  Rows r{"particles.csv", {}, {}};
  const std::string name = f.text(r.key);
  const std::filesystem::path path = beside(f, name);
  std::ifstream in(path);
  if (!std::filesystem::is_regular_file(path) || !in)
    f.fail(r.key, name + ": no such file (looked for " + path.string() + ")");
  std::vector<int> col;  // the header's columns
  std::string line;
  long number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string where = name + " line " + std::to_string(number);
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;  // blank or comment
    const auto fields = split_csv(line);
    if (col.empty()) {
      std::array<bool, kColumns> seen{};
      for (const auto& h : fields) {
        const int c = column_of(h);
        if (c < 0) f.fail(r.key, where + ": " + unknown_column(h));
        if (seen[c]) f.fail(r.key, where + ": column \"" + h + "\" appears twice");
        seen[c] = true;
        col.push_back(c);
      }
      for (int c = 0; c < kColumns; ++c)
        if (required(c) && !seen[c])
          f.fail(r.key, where + ": the header has no column \"" + kColumn[c] + "\" (required: x, y, z, d, species)");
      continue;
    }
    if (fields.size() != col.size())
      f.fail(r.key, where + ": " + std::to_string(fields.size()) + " fields, the header has " +
                        std::to_string(col.size()));
    std::array<double, kColumns> v{};
    for (std::size_t q = 0; q < fields.size(); ++q) {
      const std::string& text = fields[q];
      char* end = nullptr;
      const double x = std::strtod(text.c_str(), &end);
      if (text.empty() || end != text.c_str() + text.size())
        f.fail(r.key, where + ": " + kColumn[col[q]] + " = \"" + text + "\" is not a number");
      v[col[q]] = x;
    }
    r.values.push_back(v);
    r.label.push_back(where);
  }
  if (col.empty()) f.fail(r.key, name + ": no header line (" + column_list() + ")");
  return r;
}

// Reading one frame of the common schema (docs/output_schema.md).
struct H5Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  ~H5Handle() {
    if (id >= 0) close(id);
  }
};

Rows read_h5(SceneFile& f) {
  Rows r{"particles.h5", {}, {}};
  const std::string name = f.text(r.key);
  const long frame_given = f.integer("particles.frame", -1);
  const std::filesystem::path path = beside(f, name);
  if (!std::filesystem::is_regular_file(path)) f.fail(r.key, name + ": no such file (looked for " + path.string() + ")");
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // failures become the scene's messages
  hid_t fid = H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, H5P_DEFAULT);
  if (fid < 0) fid = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (fid < 0) f.fail(r.key, name + ": not an HDF5 file");
  const H5Handle file{fid, H5Fclose};
  std::int64_t dim = 0;
  {
    const H5Handle a{H5Aopen(file.id, "dim", H5P_DEFAULT), H5Aclose};
    if (a.id < 0 || H5Aread(a.id, H5T_NATIVE_INT64, &dim) < 0)
      f.fail(r.key, name + ": no root attribute 'dim' (not a file of the common schema, docs/output_schema.md)");
  }
  if (dim != 3) f.fail(r.key, name + ": a " + std::to_string(dim) + "D file; a particles scene reads 3D files only");
  // One frame of /frames/<ds>, width values per particle, as doubles.
  hsize_t frames = 0, n = 0;
  auto read = [&](const char* ds, hsize_t width, hsize_t frame) {
    const std::string full = std::string("/frames/") + ds;
    const H5Handle d{H5Dopen2(file.id, full.c_str(), H5P_DEFAULT), H5Dclose};
    if (d.id < 0) f.fail(r.key, name + ": no dataset " + full);
    const H5Handle space{H5Dget_space(d.id), H5Sclose};
    const int rank = H5Sget_simple_extent_ndims(space.id);
    hsize_t dims[3] = {0, 0, 0};
    if (rank != (width == 1 ? 2 : 3) || H5Sget_simple_extent_dims(space.id, dims, nullptr) < 0 ||
        (rank == 3 && dims[2] != width))
      f.fail(r.key, name + ": " + full + " is not of shape (F, N" + (width == 1 ? "" : ", " + std::to_string(width)) + ")");
    if (frame == static_cast<hsize_t>(-1)) {
      frames = dims[0];
      n = dims[1];
      return std::vector<double>();
    }
    if (dims[0] <= frame || dims[1] != n) f.fail(r.key, name + ": " + full + " does not hold frame " + std::to_string(frame) + " of " + std::to_string(n) + " particles");
    const hsize_t start[3] = {frame, 0, 0}, count[3] = {1, n, width};
    H5Sselect_hyperslab(space.id, H5S_SELECT_SET, start, nullptr, count, nullptr);
    const hsize_t m = n * width;
    const H5Handle mem{H5Screate_simple(1, &m, nullptr), H5Sclose};
    std::vector<double> out(m);
    if (m > 0 && H5Dread(d.id, H5T_NATIVE_DOUBLE, mem.id, space.id, H5P_DEFAULT, out.data()) < 0)
      f.fail(r.key, name + ": cannot read " + full);
    return out;
  };
  read("position", 3, static_cast<hsize_t>(-1));
  if (frames == 0) f.fail(r.key, name + ": holds no frames");
  const long nf = static_cast<long>(frames);
  if (frame_given < -nf || frame_given >= nf)
    f.fail("particles.frame", "frame " + std::to_string(frame_given) + " is not in " + name + ", which holds " +
                                  std::to_string(nf) + " frame(s) (0 to " + std::to_string(nf - 1) +
                                  ", or -1 for the last)");
  const hsize_t k = static_cast<hsize_t>(frame_given < 0 ? nf + frame_given : frame_given);
  const auto x = read("position", 3, k), v = read("velocity", 3, k), w = read("angular_velocity", 3, k);
  const auto d = read("diameter", 1, k), sp = read("species", 1, k), id = read("id", 1, k);
  for (hsize_t i = 0; i < n; ++i) {
    std::array<double, kColumns> row{};
    for (int c = 0; c < 3; ++c) {
      row[c] = x[3 * i + c];
      row[3 + c] = v[3 * i + c];
      row[6 + c] = w[3 * i + c];
    }
    row[9] = d[i];
    row[10] = sp[i];
    r.values.push_back(row);
    r.label.push_back("particle id " + number_text(id[i]) + " of frame " + std::to_string(k));
  }
  return r;
}

// Finite numbers, d > 0, species 0 or 1, at least one sphere.
void check_rows(const SceneFile& f, const Rows& r) {
  if (r.values.empty()) f.fail(r.key, "holds no particle (a scene needs at least one)");
  if (static_cast<double>(r.values.size()) > kMaxParticles)
    f.fail(r.key, std::to_string(r.values.size()) + " particles, more than one run can (" + number_text(kMaxParticles) + ")");
  for (std::size_t i = 0; i < r.values.size(); ++i) {
    const auto& v = r.values[i];
    for (int c = 0; c < kColumns; ++c)
      if (!std::isfinite(v[c]))
        f.fail(r.key, r.label[i] + ": " + kColumn[c] + " must be a finite number, got " + number_text(v[c]));
    if (!(v[9] > 0.0)) f.fail(r.key, r.label[i] + ": d must be > 0, got " + number_text(v[9]));
    if (v[10] != 0.0 && v[10] != 1.0)
      f.fail(r.key, r.label[i] + ": species must be 0 (small) or 1 (big), got " + number_text(v[10]));
  }
}

// No two spheres closer than 60 % of their contact distance 2^(1/6) d_ij
// (Eq. (1); the health check's limit, engine/health.hpp), found through a
// grid of cells as wide as the largest contact distance. Returns the
// potential energy of the initial overlaps (Eq. (1)'s potential).
constexpr double kMaxOverlap = 0.4;

double check_overlaps(const SceneFile& f, const Rows& r, const std::vector<ParticlesScene::Sphere>& s, double d_max) {
  const double cell = RapaportLaw<3>::kCutFactor * d_max;
  using Key = std::tuple<long long, long long, long long>;
  auto key = [&](const Eigen::Vector3d& x) {
    return Key{static_cast<long long>(std::floor(x.x() / cell)), static_cast<long long>(std::floor(x.y() / cell)),
               static_cast<long long>(std::floor(x.z() / cell))};
  };
  std::map<Key, std::vector<std::size_t>> grid;
  for (std::size_t i = 0; i < s.size(); ++i) grid[key(s[i].x)].push_back(i);
  double energy = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto [a, b, c] = key(s[i].x);
    std::size_t worst = s.size();
    for (long long da = -1; da <= 1; ++da)
      for (long long db = -1; db <= 1; ++db)
        for (long long dc = -1; dc <= 1; ++dc) {
          const auto it = grid.find(Key{a + da, b + db, c + dc});
          if (it == grid.end()) continue;
          for (std::size_t j : it->second) {
            if (j <= i) continue;
            const double dij = 0.5 * (s[i].d + s[j].d), rc = RapaportLaw<3>::kCutFactor * dij;
            const double dist = (s[i].x - s[j].x).norm();
            if (dist >= rc) continue;
            energy += RapaportLaw<3>::potential(dist, dij);
            if ((rc - dist) / rc > kMaxOverlap) worst = std::min(worst, j);
          }
        }
    if (worst < s.size()) {
      const double dij = 0.5 * (s[i].d + s[worst].d), rc = RapaportLaw<3>::kCutFactor * dij;
      const double dist = (s[i].x - s[worst].x).norm();
      f.fail(r.key, r.label[i] + " and " + r.label[worst] + " overlap by " + number_text(100.0 * (rc - dist) / rc) +
                        " % of their contact distance 2^(1/6) d_ij = " + number_text(rc) + " (at most " +
                        number_text(100.0 * kMaxOverlap) + " %)");
    }
  }
  return energy;
}

// [[wall]]: point and normal, three numbers each; the normal normalised.
std::vector<ParticlesScene::Wall> read_walls(SceneFile& f) {
  std::vector<ParticlesScene::Wall> walls;
  if (!f.has("wall")) return walls;
  const toml::array& arr = f.array("wall");
  int k = 0;
  for (const toml::node& el : arr) {
    ++k;
    const std::string which = "wall " + std::to_string(k) + ": ";
    const long line = el.source().begin.line;
    const toml::table* t = el.as_table();
    if (!t) f.fail_at(line, "wall", which + "must be a table ([[wall]] with point and normal)");
    for (const auto& [key, node] : *t) {
      const std::string name(key.str());
      if (name != "point" && name != "normal") {
        const std::string guess = did_you_mean(name, {"point", "normal"});
        f.fail_at(node.source().begin.line, "wall." + name,
                  which + "unknown key" + (guess.empty() ? " (a wall has point and normal)" : "; did you mean wall." + guess + "?"));
      }
    }
    auto vec = [&](const char* name) {
      const std::string full = std::string("wall.") + name;
      const toml::node* n = t->get(name);
      if (!n) f.fail_at(line, full, which + "missing (required)");
      const toml::array* a = n->as_array();
      const long at = n->source().begin.line;
      if (!a || a->size() != 3) f.fail_at(at, full, which + "must be an array of three numbers [x, y, z]");
      Eigen::Vector3d v;
      for (int c = 0; c < 3; ++c) {
        const toml::node& e = *a->get(static_cast<std::size_t>(c));
        const auto num = e.value<double>();
        if (!num || !(e.is_floating_point() || e.is_integer()) || !std::isfinite(*num))
          f.fail_at(at, full, which + "must be an array of three finite numbers [x, y, z]");
        v[c] = *num;
      }
      return std::pair<Eigen::Vector3d, long>{v, at};
    };
    ParticlesScene::Wall w;
    w.point = vec("point").first;
    const auto [normal, at] = vec("normal");
    const double len = normal.norm();
    if (!(len > 0.0) || !std::isfinite(len)) f.fail_at(at, "wall.normal", which + "has zero length (it must point to the particles' side)");
    w.normal = normal / len;
    walls.push_back(w);
  }
  return walls;
}

// Every sphere on its walls' normal side, none overlapping a wall by more
// than kMaxOverlap of its contact distance 2^(1/6) d_iw. Returns the potential
// energy of the initial wall overlaps.
double check_wall_sides(SceneFile& f, const Rows& r, const ParticlesScene& s) {
  double energy = 0.0;
  for (std::size_t k = 0; k < s.walls.size(); ++k) {
    const auto& w = s.walls[k];
    const std::string which = "wall " + std::to_string(k + 1) + " (point " + vec_text(w.point) + ", normal " +
                              vec_text(w.normal) + "): ";
    // The wall's point line (the walls were read: the table has its elements).
    const toml::node* tab = f.array("wall").get(k);
    const long line = tab->as_table()->get("point")->source().begin.line;
    for (std::size_t i = 0; i < s.spheres.size(); ++i) {
      const double h = (s.spheres[i].x - w.point).dot(w.normal);
      const double diw = 0.5 * (s.spheres[i].d + s.wall_diameter), rc = RapaportLaw<3>::kCutFactor * diw;
      if (!(h > 0.0))
        f.fail_at(line, "wall.point", which + r.label[i] + " starts on the wrong side (its centre is at height " +
                                          number_text(h) + "; the particles must be on the side the normal points to)");
      if (h < rc) {
        energy += RapaportLaw<3>::potential(h, diw);
        if ((rc - h) / rc > kMaxOverlap)
          f.fail_at(line, "wall.point", which + r.label[i] + " overlaps the wall by " + number_text(100.0 * (rc - h) / rc) +
                                            " % of the contact distance 2^(1/6) d_iw = " + number_text(rc) + " (at most " +
                                            number_text(100.0 * kMaxOverlap) + " %)");
      }
    }
  }
  return energy;
}

ParticlesScene read_fields(SceneFile& f) {
  ParticlesScene s;
  f.choice("scene.kind", {"particles"});
  s.name = f.text("scene.name");
  s.description = f.text("scene.description", "");

  // Exactly one source of spheres.
  const char* sources[3] = {"particles.list", "particles.csv", "particles.h5"};
  std::vector<std::string> given;
  for (const char* k : sources)
    if (f.has(k)) given.push_back(k);
  if (given.empty())
    f.fail("particles.list", "missing (required): the spheres come from one of particles.list, particles.csv or particles.h5");
  if (given.size() > 1)
    f.fail(given[1], "only one of particles.list, particles.csv and particles.h5 may be given; " + given[0] + " is too (" +
                         f.origin(given[0]) + ")");
  if (f.has("particles.frame") && given[0] != "particles.h5")
    f.fail("particles.frame", "only with particles.h5 (the frame of that file to start from)");
  s.source = given[0];
  const Rows rows = s.source == "particles.list" ? read_list(f) : s.source == "particles.csv" ? read_csv(f) : read_h5(f);
  check_rows(f, rows);
  s.d_min = INFINITY;
  s.d_max = 0.0;
  double zlo = INFINITY, zhi = -INFINITY;
  for (const auto& v : rows.values) {
    ParticlesScene::Sphere p;
    p.x = {v[0], v[1], v[2]};
    p.v = {v[3], v[4], v[5]};
    p.w = {v[6], v[7], v[8]};
    p.d = v[9];
    p.species = static_cast<int>(v[10]);
    s.spheres.push_back(p);
    s.d_min = std::min(s.d_min, p.d);
    s.d_max = std::max(s.d_max, p.d);
    s.max_speed = std::max(s.max_speed, p.v.norm());
    zlo = std::min(zlo, p.x.z());
    zhi = std::max(zhi, p.x.z());
  }
  s.height = zhi - zlo + s.d_max;
  double energy = check_overlaps(f, rows, s.spheres, s.d_max);

  s.law = f.choice("contact.law", law_names(RapaportSceneLaws<MappingInputs>{}), "rapaport");  // contact/laws.hpp
  s.impact_speed = f.positive("contact.impact_speed", f.number("contact.impact_speed", 1.0));
  s.gamma_n = f.non_negative("contact.gamma_n", f.number("contact.gamma_n", 5.0));
  s.kappa = f.positive("contact.kappa", f.number("contact.kappa", 0.2));
  s.mu_max = f.non_negative("contact.mu_max", f.number("contact.mu_max", 0.5));
  s.wall_diameter = f.non_negative("contact.wall_diameter", f.number("contact.wall_diameter", 1.0));
  s.wall_lever = f.choice("contact.wall_spin_lever", {"paper", "pair"}, "paper");
  s.gamma_s_bb = f.non_negative("friction.gamma_s_bb", f.number("friction.gamma_s_bb"));
  s.gamma_s_ss = f.non_negative("friction.gamma_s_ss", f.number("friction.gamma_s_ss"));
  s.gamma_s_bw = f.non_negative("friction.gamma_s_bw", f.number("friction.gamma_s_bw"));
  s.gamma_s_sw = f.non_negative("friction.gamma_s_sw", f.number("friction.gamma_s_sw"));
  s.gravity = f.non_negative("gravity.g", f.number("gravity.g", 0.0));

  s.walls = read_walls(f);
  energy += check_wall_sides(f, rows, s);
  s.release_speed = std::sqrt(2.0 * energy / (s.d_min * s.d_min * s.d_min));

  f.choice("integrator.kind", {"leapfrog"}, "leapfrog");
  // Default step: the drum's rule (scene/step_rule.hpp) at the fastest impact
  // the initial state can produce.
  s.dt = f.positive("integrator.dt", f.number("integrator.dt", particles_step_rule(s).dt));
  s.skin = f.positive("neighbor.skin", f.number("neighbor.skin", 0.4));

  s.duration = f.positive("run.duration", f.number("run.duration"));
  s.snapshot_every = f.positive("run.snapshot_every", f.number("run.snapshot_every", s.duration / 100.0));
  if (s.duration / s.dt > kMaxSteps)
    f.fail("run.duration", "would take " + number_text(s.duration / s.dt) + " steps (integrator.dt " + number_text(s.dt) +
                               "), more than " + number_text(kMaxSteps));
  if (s.steps_per(s.duration) < 1)
    f.fail("run.duration", number_text(s.duration) + " time units round to 0 steps of integrator.dt " +
                               number_text(s.dt) + ": nothing would be simulated");
  check_law_settable(f, s.law, mapping_inputs(s));
  return s;
}

}  // namespace

ParticlesScene read_particles_scene(SceneFile& f) {
  static const auto known = [] {
    auto k = SceneFile::keys_read_by(read_fields, kMinimalParticles, "<built-in particles scene>");
    k.insert(k.end(), std::begin(kOptional), std::end(kOptional));
    return k;
  }();
  return f.read_checked(read_fields, known);
}

ParticleStore<3> particles_store(const ParticlesScene& s) {
  ParticleStore<3> p;
  for (const auto& q : s.spheres) {
    const double m = q.d * q.d * q.d;  // m_i = d_i^3 (Sec. III)
    p.add(q.x, q.v, q.w, q.d, m, 0.5 * s.kappa * m * q.d * q.d, q.species);  // I = kappa m d^2 / 2 (rapaport.hpp)
  }
  return p;
}

MappingInputs mapping_inputs(const ParticlesScene& s) {
  MappingInputs in = MappingInputs::parameters_of(s);
  double sum[2] = {0, 0};
  long count[2] = {0, 0};
  for (const auto& q : s.spheres) {
    sum[q.species] += q.d;
    ++count[q.species];
  }
  for (int a = 0; a < 2; ++a) {
    const int b = count[a] > 0 ? a : 1 - a;  // a species with no sphere takes the other's
    in.d[a] = sum[b] / static_cast<double>(count[b]);
  }
  in.load_height = s.height;
  return in;
}

}  // namespace granular
