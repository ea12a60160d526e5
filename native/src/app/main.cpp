// granular: the native engine's command-line program.
//   granular run SCENE [-o OUT.h5] [--force | --resume] [--set key=value]... [--threads N]
//                [--checkpoint-every MINUTES] [--checkpoint-steps N] [--device cpu|gpu|gpu-host]
//                [--replicas K]
//   granular init SCENE [-o INIT.h5] [--force] [--set key=value]...
//   granular info SCENE [--set key=value]... [--json]
//   granular bench SCENE [--threads N]... [--settle X] [--rotations R | --seconds S] [--repeat K]
//                  [--ceiling N] [--json] [--device cpu|gpu|gpu-host] [--replicas K]
//                  [--gpu-memory-order cells|ids]
//   granular devices [--json]
// SCENE is a drum (Rapaport 2002), shaken-box (Poeschel and Herrmann 1995) or
// particles (explicit spheres and plane walls, docs/particles_scene.md) scene
// file; its scene.kind picks the model. Exit status (docs/errors.md):
// 0 done, 2 refused before anything ran (bad scene, bad command line, existing
// output without --force, nothing to resume), 3 unstable run, 130/143 stopped
// by SIGINT/SIGTERM after writing a checkpoint, 1 any other failure.
#include <omp.h>
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <map>
#include <optional>

#include "app/bench_children.hpp"
#include "app/openmp_wait.hpp"
#include "app/thread_placement.hpp"
#include "engine/box.hpp"
#include "engine/drum.hpp"
#include "engine/particles.hpp"
#include "engine/run_control.hpp"
#include "gpu/box_gpu.hpp"
#include "gpu/box_model.hpp"
#include "gpu/box_run.hpp"
#include "gpu/drum_gpu.hpp"
#include "gpu/drum_model.hpp"
#include "gpu/drum_run.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"
#include "scene/step_rule.hpp"
#include "version.hpp"

using namespace granular;

namespace {

// A command line that cannot be honoured (exit 2, nothing written).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The output must not exist (unless --force) and its directory must: checked
// after the scene is read and before anything is written.
void check_output(const std::string& out, bool force) {
  namespace fs = std::filesystem;
  const fs::path p(out);
  if (fs::is_directory(p)) throw UsageError(out + ": output is a directory");
  if (fs::exists(p) && !force)
    throw UsageError(out + ": output file exists; pass --force to overwrite it (it was left untouched)");
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir)) throw UsageError(out + ": output directory " + dir.string() + " does not exist");
}

struct Loaded {
  std::string kind;
  std::optional<DrumScene> drum;
  std::optional<BoxScene> box;
  std::optional<ParticlesScene> particles;
  std::string toml, json;
  const std::string& name() const { return drum ? drum->name : particles ? particles->name : box->name; }
};

Loaded load(const std::string& path, const std::vector<std::string>& sets) {
  if (!std::filesystem::exists(path)) throw SceneError(path, "no such scene file");
  SceneFile f(path, sets);
  Loaded l;
  l.kind = f.peek_text("scene.kind");
  if (l.kind == "drum")
    l.drum = read_drum_scene(f);
  else if (l.kind == "shaken_box")
    l.box = read_box_scene(f);
  else if (l.kind == "particles")
    l.particles = read_particles_scene(f);
  else {
    const std::string guess = did_you_mean(l.kind, {"drum", "shaken_box", "particles"});
    f.fail("scene.kind", "unknown value \"" + l.kind + "\"" + (guess.empty() ? "" : "; did you mean \"" + guess + "\"?") +
                             " (allowed: \"drum\", \"shaken_box\", \"particles\")");
  }
  l.toml = f.resolved_toml();
  l.json = f.resolved_json();
  return l;
}

template <int Dim>
std::vector<long> species_counts(const ParticleStore<Dim>& p) {
  std::vector<long> c(3, 0);
  for (auto sp : p.species) ++c[static_cast<std::size_t>(sp)];
  return c;
}

// The step the scene runs at, and the rule's default beside it (scene/step_rule.hpp).
nlohmann::json step_json(const StepRule& r, double dt) {
  nlohmann::json j{{"dt", dt},
                   {"default", r.dt},
                   {"binding", r.binding},
                   {"accuracy_step", r.accuracy_step},
                   {"contact_time", r.contact_time},
                   {"steps_per_contact_required", r.steps_per_contact},
                   {"steps_per_contact", r.contact_time / dt}};
  if (r.impact_speed > 0) j["impact_speed"] = r.impact_speed;
  return j;
}

// The linear law mapped from Rapaport's and YADE's viscoelastic law mapped
// from that (scene/law_mapping.hpp), as derived["linear_law"] and
// derived["viscel_law"]; false (with linear_law.infeasible) when Rapaport's
// collisions have no linear equivalent.
bool mapped_laws_json(const MappingInputs& in, nlohmann::json& d) {
  try {
    const LinearMapping m = map_rapaport_to_linear(in);
    nlohmann::json lin;
    auto coeff = [](const LinearLaw<3>::Coeff& c) {
      return nlohmann::json{{"kn", c.kn}, {"gamma_n", c.gamma_n}, {"xgamma_t", c.xgamma_t}, {"mu", c.mu}};
    };
    auto col = [](const Collision& c) {
      return nlohmann::json{{"restitution", c.restitution}, {"contact_time", c.contact_time}};
    };
    const char* pairs[3] = {"small_small", "small_big", "big_big"};
    const char* species[2] = {"small", "big"};
    for (int k = 0; k < 3; ++k) {
      const int a = k == 2 ? 1 : 0, b = k == 0 ? 0 : 1;
      lin["pair"][pairs[k]] = coeff(m.law.pair[a * 2 + b]);
      lin["pair"][pairs[k]]["m_eff"] = m.pair_meff[k];
      lin["pair"][pairs[k]]["rapaport"] = col(m.pair_collision[k]);
      lin["pair"][pairs[k]]["linear"] = col(m.pair_linear[k]);
    }
    for (int a = 0; a < 2; ++a) {
      lin["wall"][species[a]] = coeff(m.law.wall[a]);
      lin["wall"][species[a]]["m_eff"] = m.wall_meff[a];
      lin["wall"][species[a]]["rapaport"] = col(m.wall_collision[a]);
      lin["wall"][species[a]]["linear"] = col(m.wall_linear[a]);
    }
    lin["impact_speed"] = m.impact_speed;
    lin["static_load"] = m.static_load;
    lin["diameter_scale"] = m.diameter_scale;
    lin["wall_inset"] = m.wall_inset;
    d["linear_law"] = lin;
    const ViscElMapping v = map_linear_to_viscel(in, m);
    nlohmann::json ve;
    for (int a = 0; a < 2; ++a) {
      const auto& mt = v.law.mat[a];
      ve["materials"][species[a]] = {{"kn", mt.kn}, {"cn_per_mass", mt.cn_per_mass}, {"cs_per_mass", mt.cs_per_mass}};
      const auto& w = v.law.wall[a];
      ve["wall_materials"][species[a]] = {{"kn", w.kn}, {"cn", w.cn}, {"cs", w.cs}};
      ve["mean_mass"][species[a]] = v.mean_mass[a];
    }
    ve["infeasible"] = v.infeasible;
    ve["rule"] = "YADE ViscElMat per particle: kn, cn = cn_per_mass m_i, cs = cs_per_mass m_i; walls absolute; "
                 "pair value 1/(1/a + 1/b), 0 = absent (contact/viscel.hpp)";
    d["viscel_law"] = ve;
    return true;
  } catch (const MappingError& e) {
    d["linear_law"] = {{"infeasible", e.what()}};  // refused if the scene's law needs it
    return false;
  }
}

// The registered contact laws this scene kind can use (contact/laws.hpp),
// each with the contact.law and contact.damping keys that select it.
template <class L>
nlohmann::json contact_laws_json(L) {
  nlohmann::json laws = nlohmann::json::array();
  for_each_type(L{}, [&](auto tag) {
    using Law = typename decltype(tag)::type;
    laws.push_back({{"contact.law", Law::kName},
                    {"contact.damping", damping_name(DampingOf<Law>::value)},
                    {"vectorised", Law::kVectorised},
                    {"range_factor", Law::kRangeFactor}});
  });
  return laws;
}

nlohmann::json info_json(const Loaded& l) {
  auto j = nlohmann::json::parse(l.json);
  nlohmann::json d;
  if (l.drum) {
    const DrumScene& s = *l.drum;
    const auto p = drum_particles(s);
    const auto c = species_counts(p);
    d["particles"] = p.size();
    d["particles_small"] = c[0];
    d["particles_big"] = c[1];
    if (s.paper_n > 0) {
      d["paper_particles"] = s.paper_n;
      d["particles_vs_paper_percent"] = 100.0 * (static_cast<double>(p.size()) / s.paper_n - 1.0);
    }
    d["time_step"] = step_json(drum_step_rule(s), s.dt);
    d["rotation_period"] = s.rotation_period();
    d["steps_per_rotation"] = s.rotation_period() / s.dt;
    d["steps_total"] = s.steps_per(s.rotations);
    // The linear law mapped from Rapaport's (what LAMMPS runs, and the native
    // engine with contact.law = "linear") and YADE's law mapped from that:
    // docs/model_mapping.md.
    if (mapped_laws_json(mapping_inputs(s), d)) {
      const double inset = d["linear_law"]["wall_inset"].get<double>();
      d["linear_law"]["contact_diameter"] = s.diameter - 2.0 * inset;
      d["linear_law"]["contact_length"] = s.length - (s.capped ? 2.0 * inset : 0.0);
    }
  } else if (l.particles) {
    const ParticlesScene& s = *l.particles;
    long small = 0;
    for (const auto& q : s.spheres) small += q.species == 0;
    d["particles"] = s.spheres.size();
    d["particles_small"] = small;
    d["particles_big"] = static_cast<long>(s.spheres.size()) - small;
    d["walls"] = s.walls.size();
    d["source"] = s.source;
    d["max_speed"] = s.max_speed;
    d["release_speed"] = s.release_speed;
    d["time_step"] = step_json(particles_step_rule(s), s.dt);
    d["steps_total"] = s.steps_per(s.duration);
    // The same maps as the drum's, from the particles' species (docs/particles_scene.md):
    // what contact.law = "linear" and "viscel" run, and what LAMMPS and YADE are given.
    mapped_laws_json(mapping_inputs(s), d);
  } else {
    const BoxScene& s = *l.box;
    std::vector<Eigen::Vector2d> anchors;
    double top = 0.0;  // the side walls' top centre, particle or smooth
    const auto p = box_particles(s, anchors, &top);
    const auto c = species_counts(p);
    d["particles"] = p.size();
    d["grains"] = c[0];
    d["big_disks"] = c[1];
    d["wall_particles"] = c[2];
    d["walls"] = s.smooth_walls ? "smooth" : "particles";
    d["wall_height_built"] = top + s.wall_radius;
    const double w = 2.0 * M_PI * s.frequency;
    d["peak_acceleration_over_g"] = s.gravity > 0 ? s.amplitude * w * w / s.gravity : 0.0;  // Gamma
    d["steps_total"] = std::lround((s.settle + s.duration) / s.dt);
    d["time_step"] = step_json(box_step_rule(s), s.dt);
  }
  d["contact_laws"] = l.drum ? contact_laws_json(DrumLaws{})
                   : l.particles ? contact_laws_json(RapaportSceneLaws<MappingInputs>{})
                                 : contact_laws_json(BoxLaws{});
  j["derived"] = d;
  return j;
}

template <int Dim>
void common_attrs(H5Output& out, const Loaded& l, const std::string& scene_path) {
  out.attr("engine", std::string("granular-native"));
  out.attr("engine_version", std::string(kVersion));
  out.attr("scene_kind", l.kind);
  out.attr("scene_name", l.name());
  out.attr("scene_file", scene_path);
  out.attr("scene_toml", l.toml);
  out.attr("scene_json", l.json);
  out.attr("threads", static_cast<std::int64_t>(omp_get_max_threads()));
}

// Peak resident set size of this program: VmHWM of /proc/self/status, the high
// water mark of this memory image. getrusage's ru_maxrss is not used where
// VmHWM exists: Linux carries it over from the image before exec, so a run
// started from a large parent (Python's subprocess) would report the parent's.
double peak_rss_bytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return 1024.0 * std::stod(line.substr(6));  // "VmHWM:   12808 kB"
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1024.0 * static_cast<double>(u.ru_maxrss);
}

struct RunOptions {
  bool quiet = false, force = false, resume = false;
  bool threads_given = false;
  double checkpoint_minutes = 10.0;
  long checkpoint_steps = 0;
  std::string device = "cpu";
  int replicas = 0;  // --replicas K (0: not given, one run named as given)
  std::vector<std::string> sets;
};

// --device gpu and gpu-host (docs/gpu.md): the GPU engine, on a CUDA device
// or with its kernels built by the host compiler and run on the CPU (a
// device for checking the GPU engine without a GPU). Refused, with the
// reason, before anything is written: a scene the GPU engine does not run
// (gpu/stepper_driver.hpp, unsupported_scene), --device gpu in a build without
// CUDA or without a visible CUDA device, --replicas on the CPU.
void check_device(const std::string& device, int replicas, const Loaded& l) {
  if (device == "cpu") {
    if (replicas > 0) throw UsageError("--replicas: replicas run on the GPU engine only (--device gpu or gpu-host)");
    return;
  }
  const std::string why = gpu::unsupported_scene(l.kind);
  if (!why.empty()) throw UsageError("--device " + device + ": " + why + "; run it with --device cpu");
  if (device != "gpu") return;
#if defined(GRANULAR_HAVE_CUDA)
  const std::string none = gpu::cuda_unavailable();
  if (!none.empty()) throw UsageError("--device gpu: " + none + "; run on the CPU with --device cpu");
#else
  throw UsageError("--device gpu: this granular was built without CUDA (docs/gpu.md); run on the CPU with "
                   "--device cpu");
#endif
}

// granular devices: where --device can run here. cpu and gpu-host always
// (the cores); gpu where this build has CUDA and a CUDA device is visible,
// else the reason it cannot. For scripts that choose a device
// (compare validate --device auto): --json.
int print_devices(bool as_json) {
  nlohmann::json gpu{{"built", false}, {"available", false}, {"why_not", "this granular was built without CUDA"}};
#if defined(GRANULAR_HAVE_CUDA)
  const std::string none = gpu::cuda_unavailable();
  gpu = {{"built", true}, {"available", none.empty()}, {"why_not", none}};
  if (none.empty()) gpu["free_bytes"] = gpu::cuda_free_bytes();
#endif
  const nlohmann::json j{{"cpu", {{"available", true}, {"cores", omp_get_num_procs()}}},
                         {"gpu-host", {{"available", true}, {"cores", omp_get_num_procs()}}},
                         {"gpu", gpu}};
  if (as_json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::printf("cpu       available, %d cores\ngpu-host  available, %d cores\n", omp_get_num_procs(),
              omp_get_num_procs());
  if (gpu["available"].get<bool>())
    std::printf("gpu       available, %.2f GiB free\n", gpu["free_bytes"].get<double>() / (1 << 30));
  else
    std::printf("gpu       not available: %s\n", gpu["why_not"].get<std::string>().c_str());
  return 0;
}

// The stepper of the GPU engine on a device (gpu: CUDA; gpu-host: the host
// build of the same kernels).
gpu::StepperFactory stepper_factory(const std::string& device) {
#if defined(GRANULAR_HAVE_CUDA)
  if (device == "gpu") return &gpu::make_cuda_drum;
#endif
  if (device == "gpu-host") return static_cast<gpu::StepperFactory>(&gpu::make_host_drum);
  throw UsageError("--device " + device + ": not a GPU engine device");
}

// The same for the shaken box.
gpu::BoxStepperFactory box_stepper_factory(const std::string& device) {
#if defined(GRANULAR_HAVE_CUDA)
  if (device == "gpu") return static_cast<gpu::BoxStepperFactory>(&gpu::make_cuda_box);
#endif
  if (device == "gpu-host") return static_cast<gpu::BoxStepperFactory>(&gpu::make_host_box);
  throw UsageError("--device " + device + ": not a GPU engine device");
}

// Before a CUDA run: the device memory the replicas need (gpu/drum_gpu.hpp,
// device_bytes) against the device's free memory; refused if it does not fit.
// n: the particles of one replica (the first).
void check_device_bytes(const std::string& device, const gpu::DeviceSizing& z, int replicas, std::size_t n) {
#if defined(GRANULAR_HAVE_CUDA)
  if (device != "gpu") return;
  const double need = static_cast<double>(gpu::device_bytes(z));
  const double free = static_cast<double>(gpu::cuda_free_bytes());
  if (need > free) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "--device gpu: the run needs about %.2f GiB of GPU memory (%d replica(s) of %zu particles), the GPU "
                  "has %.2f GiB free; run fewer replicas or a smaller scene",
                  need / 1073741824.0, replicas, n, free / 1073741824.0);
    throw UsageError(buf);
  }
#else
  (void)device;
  (void)z;
  (void)replicas;
  (void)n;
#endif
}

// The same for replicas of a drum like sim.
void check_device_memory(const std::string& device, const DrumSim& sim, int replicas) {
  if (device != "gpu") return;
  const gpu::DrumModel m = gpu::drum_model(sim);
  check_device_bytes(device, gpu::drum_sizing(m, replicas), replicas, m.p.size());
}

// The same for the boxes of models (one a replica).
void check_device_memory(const std::string& device, const std::vector<gpu::BoxModel>& models) {
  if (device != "gpu" || models.empty()) return;
  check_device_bytes(device, gpu::box_sizing(models), static_cast<int>(models.size()), models.front().p.size());
}

// Replica k's output: OUT's stem + "_r" + k (two digits, more where K > 100) + OUT's extension.
std::string replica_output(const std::string& out, int k, int replicas) {
  const std::filesystem::path p(out);
  int width = 2;
  for (int m = replicas - 1; m >= 100; m /= 10) ++width;
  std::string num = std::to_string(k);
  num.insert(0, static_cast<std::size_t>(std::max(0, width - static_cast<int>(num.size()))), '0');
  return (p.parent_path() / (p.stem().string() + "_r" + num + p.extension().string())).string();
}

// Keys of the resolved scene, flattened to "section.key", with their values.
void flatten(const nlohmann::json& j, const std::string& prefix, std::map<std::string, std::string>& out) {
  if (j.is_object()) {
    for (const auto& [k, v] : j.items()) flatten(v, prefix.empty() ? k : prefix + "." + k, out);
  } else {
    out[prefix] = j.dump();
  }
}

// Scene keys added to the engine after checkpoints were already being written,
// with the value that reproduces the run as it was before the key existed. A
// checkpoint's scene that lacks one of these resumes only at that value.
const std::map<std::string, std::string> kKeysAddedLater = {
    {"box.walls", "\"particles\""},
    {"particles.rotation", "true"},
    {"run.final_snapshots", "0"},
    {"run.final_snapshot_every", "5.0"},
};

// A run resumes only with the scene it was started with; only its length
// (run.rotations, run.duration) may grow.
void check_same_scene(const std::string& ckpt_path, const std::string& saved_json, const std::string& json) {
  std::map<std::string, std::string> a, b;
  flatten(nlohmann::json::parse(saved_json), "", a);
  flatten(nlohmann::json::parse(json), "", b);
  for (const auto& [k, v] : a)
    if (k != "run.rotations" && k != "run.duration" && (!b.count(k) || b[k] != v))
      throw UsageError(ckpt_path + ": the checkpoint was written for " + k + " = " + v + ", the scene now gives " +
                       (b.count(k) ? b[k] : std::string("nothing")) +
                       "; resume with the same scene file and --set options (only run.rotations or run.duration "
                       "may change)");
  for (const auto& [k, v] : b) {
    if (a.count(k)) continue;
    const auto added = kKeysAddedLater.find(k);
    if (added != kKeysAddedLater.end() && added->second == v) continue;  // the run as it was
    throw UsageError(ckpt_path + ": the scene now has " + k + " = " + v + ", which the checkpoint's scene had not" +
                     (added != kKeysAddedLater.end() ? " (it was written before " + k + " existed, i.e. with " + k +
                                                           " = " + added->second + ")"
                                                     : std::string()));
  }
}

// The checkpoint beside out_path that --resume continues from, written for
// the scene `json`, by the GPU engine (gpu) or the CPU engine; refused with
// the reason otherwise.
CheckpointData checkpoint_to_resume(const std::string& out_path, const std::string& json, bool gpu) {
  const std::string ckpt_path = checkpoint_path(out_path);
  if (!std::filesystem::exists(out_path)) throw UsageError(out_path + ": no output file to resume");
  if (!std::filesystem::exists(ckpt_path))
    throw UsageError(ckpt_path + ": no checkpoint to resume from (a run writes one every --checkpoint-every "
                                 "minutes, on SIGINT/SIGTERM and at its end; start the run again with --force)");
  CheckpointData saved;
  try {
    saved = read_checkpoint(ckpt_path);
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
  check_same_scene(ckpt_path, saved.scene_json, json);
  const bool by_gpu = saved.ints.count(gpu::kCheckpointKey) > 0;
  if (gpu && !by_gpu)
    throw UsageError(ckpt_path + ": the checkpoint was written by --device cpu; resume it with --device cpu");
  if (!gpu && by_gpu)
    throw UsageError(ckpt_path + ": the checkpoint was written by the GPU engine; resume it with --device gpu or "
                                 "--device gpu-host");
  return saved;
}

// A particles scene keeps no checkpoint: it runs from its scene file alone.
int run_particles_scene(const Loaded& l, const std::string& scene_path, std::string out_path, const RunOptions& o) {
  if (o.resume)
    throw UsageError(scene_path + ": --resume is not available for a particles scene (its runs keep no checkpoint); "
                                  "run it again with --force");
  if (out_path.empty()) out_path = l.name() + ".h5";
  check_output(out_path, o.force);
  install_stop_handlers();
  const ParticlesScene& s = *l.particles;
  ParticlesSim sim = make_particles(s);
  const auto n = std::visit([](auto& v) { return v.p.size(); }, sim);
  H5Output out(out_path, 3, static_cast<std::int64_t>(n));
  common_attrs<3>(out, l, scene_path);
  out.group_attr("frames", "species_names", {"small", "big"});
  std::fprintf(stderr, "granular %s: particles %s (%s), %zu particles, %zu wall(s), %.4g time units, %d thread(s) -> %s\n",
               kVersion, s.name.c_str(), scene_path.c_str(), n, s.walls.size(), s.duration, omp_get_max_threads(),
               out_path.c_str());
  const RunReport r = run_particles(s, sim, &out, !o.quiet && isatty(fileno(stderr)));
  std::fprintf(stderr, "done: %ld steps in %.1f s, %.3g particle-steps/s\n%s", r.steps, r.seconds,
               r.particle_steps_per_second, format_breakdown(r.breakdown).c_str());
  return 0;
}

// A drum or box run's checkpoints (OUT.h5.ckpt at the options' cadence,
// resumed from `saved` if given) and the metadata they carry
// (engine/run_control.hpp).
RunControl run_control(const Loaded& l, const RunOptions& o, const std::string& out_path,
                       const CheckpointData* saved) {
  RunControl ctl;
  ctl.checkpoint = checkpoint_path(out_path);
  ctl.every_seconds = 60.0 * o.checkpoint_minutes;
  ctl.every_steps = o.checkpoint_steps;
  ctl.resume = saved;
  ctl.meta.scene_json = l.json;
  ctl.meta.engine_version = kVersion;
  ctl.meta.threads = omp_get_max_threads();
  ctl.meta.seed = static_cast<std::int64_t>(l.drum ? l.drum->seed : l.box->seed);
  return ctl;
}

// The members of a run on the GPU engine (docs/gpu.md): one scene, or with
// --replicas K its seeds particles.seed + k, k < K (seed: the scene's), each
// replica with its own output (replica_output) and checkpoint; the
// checkpoints to resume from (all of one step), or the outputs checked free.
struct GpuMembers {
  int replicas = 1;
  std::vector<Loaded> scenes;
  std::vector<std::string> outs;
  std::vector<std::optional<CheckpointData>> saved;
};

GpuMembers gpu_members(const Loaded& l, const std::string& scene_path, const std::string& out_path,
                       const RunOptions& o, std::uint64_t seed) {
  GpuMembers g;
  g.replicas = std::max(1, o.replicas);
  for (int k = 0; k < g.replicas; ++k) {
    if (o.replicas > 0) {
      std::vector<std::string> sets = o.sets;
      sets.push_back("particles.seed=" + std::to_string(seed + static_cast<std::uint64_t>(k)));
      g.scenes.push_back(load(scene_path, sets));
      g.outs.push_back(replica_output(out_path, k, g.replicas));
    } else {
      g.scenes.push_back(l);
      g.outs.push_back(out_path);
    }
  }
  g.saved.resize(g.replicas);
  for (int k = 0; k < g.replicas; ++k) {
    const std::string ckpt_path = checkpoint_path(g.outs[k]);
    if (o.resume) {
      g.saved[k] = checkpoint_to_resume(g.outs[k], g.scenes[k].json, true);
      if (g.saved[k]->step != g.saved[0]->step)
        throw UsageError(ckpt_path + ": the replicas' checkpoints are of different steps (" +
                         std::to_string(g.saved[k]->step) + " and " + std::to_string(g.saved[0]->step) + ")");
    } else {
      check_output(g.outs[k], o.force);
    }
  }
  return g;
}

// After the members are made: a new run removes the checkpoints of earlier
// runs into its outputs; then SIGINT and SIGTERM checkpoint and stop.
void begin_gpu_run(const GpuMembers& g, const RunOptions& o) {
  if (!o.resume)
    for (const std::string& out : g.outs) std::filesystem::remove(checkpoint_path(out));  // an earlier run's
  install_stop_handlers();
}

// A drum run on the GPU engine (docs/gpu.md): one scene, or with --replicas K
// its seeds particles.seed + k, k < K, side by side in one stepper, each
// replica writing its own output (replica_output) and checkpoint.
int run_gpu_drum(const Loaded& l, const std::string& scene_path, std::string out_path, const RunOptions& o) {
  if (out_path.empty()) out_path = l.name() + ".h5";
  const GpuMembers g = gpu_members(l, scene_path, out_path, o, l.drum->seed);
  const int replicas = g.replicas;
  const std::vector<Loaded>& scenes = g.scenes;
  const std::vector<std::string>& outs = g.outs;
  const auto& saved = g.saved;
  std::vector<DrumSim> sims;
  sims.reserve(replicas);
  for (int k = 0; k < replicas; ++k) sims.push_back(make_drum(*scenes[k].drum));
  check_device_memory(o.device, sims.front(), replicas);
  begin_gpu_run(g, o);
  const DrumScene& s = *l.drum;
  std::vector<std::unique_ptr<H5Output>> files;
  std::vector<DrumMember> members;
  std::vector<DrumSim*> ptrs;
  std::size_t n = 0;
  for (int k = 0; k < replicas; ++k) {
    const auto nk = std::visit([](auto& v) { return v.p.size(); }, sims[k]);
    n += nk;
    files.push_back(std::make_unique<H5Output>(outs[k], 3, static_cast<std::int64_t>(nk), false,
                                               saved[k] ? &saved[k]->rows : nullptr));
    H5Output& out = *files.back();
    common_attrs<3>(out, scenes[k], scene_path);
    out.attr("omega", s.omega);
    out.attr("rotation_period", s.rotation_period());
    out.group_attr("frames", "species_names", {"small", "big"});
    members.push_back({&sims[k], &out, run_control(scenes[k], o, outs[k], saved[k] ? &*saved[k] : nullptr)});
    ptrs.push_back(&sims[k]);
  }
  std::fprintf(stderr, "granular %s: drum %s (%s), %zu particles, %.4g rotations, device %s", kVersion,
               s.name.c_str(), scene_path.c_str(), n, s.rotations, o.device.c_str());
  if (o.replicas > 0)
    std::fprintf(stderr, ", %d replicas (particles.seed %llu to %llu) -> %s ... %s\n", replicas,
                 static_cast<unsigned long long>(s.seed), static_cast<unsigned long long>(s.seed + replicas - 1),
                 outs.front().c_str(), outs.back().c_str());
  else
    std::fprintf(stderr, " -> %s\n", out_path.c_str());
  if (saved[0])
    std::fprintf(stderr, "resuming from step %lld (rotation %.4g)\n", static_cast<long long>(saved[0]->step),
                 saved[0]->time / s.rotation_period());
  const auto driver = gpu::make_drum_driver(s, ptrs, stepper_factory(o.device), outs);
  const RunReport r = run_drums(s, members, *driver, !o.quiet && isatty(fileno(stderr)));
  std::fprintf(stderr, "done: %ld steps in %.1f s, %.3g particle-steps/s\n", r.steps, r.seconds,
               r.particle_steps_per_second);
  return 0;
}

// The shaken box's output file, with the attributes of its scene.
std::unique_ptr<H5Output> open_box_output(const Loaded& l, const std::string& scene_path, const std::string& out_path,
                                          std::size_t n, const RowCounts* rows) {
  const BoxScene& s = *l.box;
  auto out = std::make_unique<H5Output>(out_path, 2, static_cast<std::int64_t>(n), true, rows);
  common_attrs<2>(*out, l, scene_path);
  out->attr("frequency", s.frequency);
  out->attr("amplitude", s.amplitude);
  out->attr("settle", s.settle);
  out->attr("box_width", s.width);
  out->attr("wall_radius", s.wall_radius);
  out->group_attr("frames", "species_names", {"small", "big", "wall"});
  return out;
}

// A shaken-box run on the GPU engine (docs/gpu.md): the CPU engine's run
// loop, output and checkpoints, stepped by the box's GPU stepper; one scene,
// or with --replicas K its seeds particles.seed + k, k < K, side by side in
// one stepper, each replica writing its own output (replica_output) and
// checkpoint, as a drum's.
int run_gpu_box(const Loaded& l, const std::string& scene_path, std::string out_path, const RunOptions& o) {
  if (out_path.empty()) out_path = l.name() + ".h5";
  const GpuMembers g = gpu_members(l, scene_path, out_path, o, l.box->seed);
  const int replicas = g.replicas;
  std::vector<BoxSim> sims;
  sims.reserve(replicas);
  for (int k = 0; k < replicas; ++k) sims.push_back(make_box(*g.scenes[k].box));
  if (o.device == "gpu") {
    std::vector<gpu::BoxModel> models;
    for (const BoxSim& sim : sims) models.push_back(gpu::box_model(sim));
    check_device_memory(o.device, models);
  }
  begin_gpu_run(g, o);
  const BoxScene& s = *l.box;
  std::vector<std::unique_ptr<H5Output>> files;
  std::vector<BoxMember> members;
  std::vector<BoxSim*> ptrs;
  std::size_t n = 0;
  for (int k = 0; k < replicas; ++k) {
    const auto nk = std::visit([](auto& v) { return v.p.size(); }, sims[k]);
    n += nk;
    const auto& saved = g.saved[k];
    files.push_back(open_box_output(g.scenes[k], scene_path, g.outs[k], nk, saved ? &saved->rows : nullptr));
    members.push_back({&sims[k], files.back().get(), run_control(g.scenes[k], o, g.outs[k], saved ? &*saved : nullptr)});
    ptrs.push_back(&sims[k]);
  }
  std::fprintf(stderr, "granular %s: shaken box %s (%s), %zu particles, %.3g s settling + %.4g s shaking, device %s",
               kVersion, s.name.c_str(), scene_path.c_str(), n, s.settle, s.duration, o.device.c_str());
  if (o.replicas > 0)
    std::fprintf(stderr, ", %d replicas (particles.seed %llu to %llu) -> %s ... %s\n", replicas,
                 static_cast<unsigned long long>(s.seed), static_cast<unsigned long long>(s.seed + replicas - 1),
                 g.outs.front().c_str(), g.outs.back().c_str());
  else
    std::fprintf(stderr, " -> %s\n", out_path.c_str());
  if (g.saved[0])
    std::fprintf(stderr, "resuming from step %lld (t = %.6g s)\n", static_cast<long long>(g.saved[0]->step),
                 g.saved[0]->time);
  const auto driver = gpu::make_box_driver(s, ptrs, box_stepper_factory(o.device), g.outs);
  const RunReport r = run_boxes(s, members, *driver, !o.quiet && isatty(fileno(stderr)));
  std::fprintf(stderr, "done: %ld steps in %.1f s, %.3g particle-steps/s\n", r.steps, r.seconds,
               r.particle_steps_per_second);
  return 0;
}

int run_scene(const Loaded& l, const std::string& scene_path, std::string out_path, const RunOptions& o) {
  if (l.particles) return run_particles_scene(l, scene_path, out_path, o);
  if (o.device != "cpu") return l.box ? run_gpu_box(l, scene_path, out_path, o) : run_gpu_drum(l, scene_path, out_path, o);
  if (out_path.empty()) out_path = l.name() + ".h5";
  const std::string ckpt_path = checkpoint_path(out_path);
  std::optional<CheckpointData> saved;
  if (o.resume) {
    saved = checkpoint_to_resume(out_path, l.json, false);
    if (!o.threads_given)
      omp_set_num_threads(static_cast<int>(saved->threads));
    else if (saved->threads != omp_get_max_threads())
      std::fprintf(stderr,
                   "warning: the checkpoint was written with %lld thread(s), this run uses %d: forces are summed in "
                   "another order, so the continuation is statistically, not bitwise, the same run\n",
                   static_cast<long long>(saved->threads), omp_get_max_threads());
  } else {
    check_output(out_path, o.force);
    std::filesystem::remove(ckpt_path);  // a checkpoint of an earlier run into this output
  }
  install_stop_handlers();
  place_threads();  // the team is final here (app/thread_placement.hpp)
  RunControl ctl = run_control(l, o, out_path, saved ? &*saved : nullptr);
  const RowCounts* rows = saved ? &saved->rows : nullptr;
  const bool progress = !o.quiet && isatty(fileno(stderr));
  RunReport r;
  if (l.drum) {
    const DrumScene& s = *l.drum;
    DrumSim sim = make_drum(s);
    const auto n = std::visit([](auto& v) { return v.p.size(); }, sim);
    H5Output out(out_path, 3, static_cast<std::int64_t>(n), false, rows);
    common_attrs<3>(out, l, scene_path);
    out.attr("omega", s.omega);
    out.attr("rotation_period", s.rotation_period());
    out.group_attr("frames", "species_names", {"small", "big"});
    std::fprintf(stderr, "granular %s: drum %s (%s), %zu particles, %.4g rotations, %d thread(s) -> %s\n", kVersion,
                 s.name.c_str(), scene_path.c_str(), n, s.rotations, omp_get_max_threads(), out_path.c_str());
    if (saved)
      std::fprintf(stderr, "resuming from step %lld (rotation %.4g)\n", static_cast<long long>(saved->step),
                   saved->time / s.rotation_period());
    r = run_drum(s, sim, &out, progress, ctl);
  } else {
    const BoxScene& s = *l.box;
    BoxSim sim = make_box(s);
    const auto n = std::visit([](auto& v) { return v.p.size(); }, sim);
    const auto out = open_box_output(l, scene_path, out_path, n, rows);
    std::fprintf(stderr, "granular %s: shaken box %s (%s), %zu particles, %.3g s settling + %.4g s shaking, %d thread(s) -> %s\n",
                 kVersion, s.name.c_str(), scene_path.c_str(), n, s.settle, s.duration, omp_get_max_threads(),
                 out_path.c_str());
    if (saved)
      std::fprintf(stderr, "resuming from step %lld (t = %.6g s)\n", static_cast<long long>(saved->step), saved->time);
    r = run_box(s, sim, out.get(), progress, ctl);
  }
  std::fprintf(stderr, "done: %ld steps in %.1f s, %.3g particle-steps/s\n%s", r.steps, r.seconds,
               r.particle_steps_per_second, format_breakdown(r.breakdown).c_str());
  return 0;
}

// The initial state in the common schema (one frame at t = 0) plus each
// particle's mass and moment of inertia (group /initial, rows in id order) and
// the derived parameters (attribute derived_json): what another engine needs to
// start from the same configuration (lammps_cases/, yade_cases/).
template <class Sim>
void write_initial(H5Output& out, const Sim& sim) {
  out.frame(0.0, 0, sim.p);
  std::vector<std::size_t> order(sim.p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return sim.p.id[a] < sim.p.id[b]; });
  const int h = out.init_series("initial", {{"id", 1}, {"mass", 1}, {"inertia", 1}});
  for (std::size_t i : order)
    out.series(h, {{static_cast<double>(sim.p.id[i])}, {1.0 / sim.p.inv_m[i]}, {1.0 / sim.p.inv_i[i]}});
}

int init_scene(const Loaded& l, const std::string& scene_path, std::string out_path, bool force) {
  if (out_path.empty()) out_path = l.name() + "_init.h5";
  check_output(out_path, force);
  const int dim = l.box ? 2 : 3;
  auto emit = [&](auto& sim) {
    H5Output out(out_path, dim, static_cast<std::int64_t>(sim.p.size()));
    if (l.particles) {
      common_attrs<3>(out, l, scene_path);
      out.group_attr("frames", "species_names", {"small", "big"});
    } else if (l.drum) {
      common_attrs<3>(out, l, scene_path);
      out.attr("omega", l.drum->omega);
      out.attr("rotation_period", l.drum->rotation_period());
      out.group_attr("frames", "species_names", {"small", "big"});
    } else {
      common_attrs<2>(out, l, scene_path);
      out.attr("frequency", l.box->frequency);
      out.attr("amplitude", l.box->amplitude);
      out.attr("settle", l.box->settle);
      out.attr("box_width", l.box->width);
      out.attr("wall_radius", l.box->wall_radius);
      out.group_attr("frames", "species_names", {"small", "big", "wall"});
    }
    out.attr("derived_json", info_json(l).dump());
    write_initial(out, sim);
  };
  if (l.drum) {
    DrumSim sim = make_drum(*l.drum);
    std::visit(emit, sim);
  } else if (l.particles) {
    ParticlesSim sim = make_particles(*l.particles);
    std::visit(emit, sim);
  } else {
    BoxSim sim = make_box(*l.box);
    std::visit(emit, sim);
  }
  return 0;
}

// A run's breakdown for `granular bench --json`: seconds per phase, and the
// pair loop beside the bare kernel (engine/timers.hpp).
nlohmann::json breakdown_json(const StepBreakdown& b) {
  nlohmann::json ph;
  for (int k = 0; k < static_cast<int>(Phase::count); ++k) ph[PhaseTimers::name(static_cast<Phase>(k))] = b.seconds[k];
  nlohmann::json j{{"phase_seconds", ph},
                   {"seconds", b.total_seconds},
                   {"steps", b.steps},
                   {"threads", b.threads},
                   {"pairs_listed", b.pairs_listed},
                   {"tail_tasks", b.tail_tasks},
                   {"tails_taken_per_step", b.tails_taken_per_step},
                   {"steal_windows", b.steal_windows},
                   {"steal_windows_stealing", b.steal_windows_stealing}};
  if (b.contacts > 0)
    j.update({{"contacts", b.contacts},
              {"pair_loop_ns_per_contact", b.pair_loop_ns},
              {"bare_kernel_ns_per_contact", b.bare_kernel_ns}});
  return j;
}

// granular bench: settle once (one thread), then `rounds` rounds, each timing
// every thread count once and, with ceiling > 0, that many 1-thread runs at
// once, every run a child forked from the settled state (app/bench_children.hpp).
// Per thread count: the median over the rounds, the spread, every round's rate
// and the phase timers of the median round; per round, the rate over the
// first thread count's in the same round (the steadier figure on a shared
// host: its two runs were seconds apart).
constexpr double kWarm = 0.05;  // run_bench: the untimed start of each run, a share of the timed stretch

int run_bench(const Loaded& l, const std::vector<int>& threads, int rounds, int ceiling, double settle, double span,
              bool as_json) {
  omp_set_num_threads(1);
  std::optional<DrumSim> drum;
  std::optional<BoxSim> box;
  if (l.drum)
    drum = settle_drum(*l.drum, settle < 0 ? 0.5 : settle);
  else
    box = settle_box(*l.box, settle < 0 ? 1.0 : settle);
  const double settled_peak = peak_rss_bytes();
  const auto now = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
  // `length` rotations (drum) or seconds (box) from the state in hand.
  const auto stretch = [&](double length) {
    return drum ? time_drum(*l.drum, *drum, length) : time_box(*l.box, *box, length);
  };
  const auto timed = [&] {
    // Untimed first: the first 5 % of the stretch, on the child's threads. The
    // child shares the parent's pages until it writes them, and its first
    // writes copy them, a page fault each (with two threads, likely also a
    // flush of the other core's address map). Timed from the first step, a
    // 2-thread drum run lost 1-12 % (8 of 8 rounds) against the same run in
    // one process; with this start, 0.99 (docs/speed_accuracy.md, "One settled state per round").
    // Its buffers take their size for the thread count here too, as a run's
    // do in its first steps.
    stretch(kWarm * span);
    const double begun = now();  // the system's monotonic clock: the same in every process
    const RunReport r = stretch(span);
    return nlohmann::json{{"rate", r.particle_steps_per_second}, {"particles", r.particles},
                          {"begun", begun}, {"ended", now()},
                          {"seconds", r.seconds}, {"steps", r.steps}, {"neighbor_builds", r.neighbor_builds},
                          {"timing", format_breakdown(r.breakdown)}, {"breakdown", breakdown_json(r.breakdown)},
                          {"peak_rss_bytes", peak_rss_bytes()}};
  };
  struct Series {
    int threads, copies;
    std::vector<nlohmann::json> runs;  // per round (copies: the first child's, its rate the sum)
  };
  std::vector<Series> series;
  for (int t : threads) series.push_back({t, 1, {}});
  if (ceiling > 0) series.push_back({1, ceiling, {}});
  for (int k = 0; k < rounds; ++k)
    for (Series& s : series) {
      std::vector<nlohmann::json> kids = bench::in_children(timed, s.threads, s.copies);
      nlohmann::json run = kids.front();
      double sum = 0.0, begun = 0.0, ended = INFINITY, shortest = INFINITY;
      for (const auto& c : kids) {
        sum += c["rate"].get<double>();
        begun = std::max(begun, c["begun"].get<double>());
        ended = std::min(ended, c["ended"].get<double>());
        shortest = std::min(shortest, c["ended"].get<double>() - c["begun"].get<double>());
        run["copy_rates"].push_back(c["rate"]);
      }
      run["rate"] = sum;
      // The share of the shortest run during which every copy ran.
      run["overlap"] = std::max(0.0, ended - begun) / shortest;
      s.runs.push_back(std::move(run));
    }
  nlohmann::json res = nlohmann::json::array();
  for (const Series& s : series) {
    std::vector<double> rates, per_round;
    for (std::size_t k = 0; k < s.runs.size(); ++k) {
      rates.push_back(s.runs[k]["rate"].get<double>());
      per_round.push_back(rates.back() / series.front().runs[k]["rate"].get<double>());
    }
    std::vector<std::size_t> by(rates.size());
    for (std::size_t k = 0; k < by.size(); ++k) by[k] = k;
    std::sort(by.begin(), by.end(), [&](std::size_t a, std::size_t b) { return rates[a] < rates[b]; });
    const nlohmann::json& med = s.runs[by[by.size() / 2]];
    std::vector<double> pr = per_round;
    std::sort(pr.begin(), pr.end());
    const double rate = med["rate"].get<double>(), ratio = pr[pr.size() / 2];
    const double particles = med["particles"].get<double>();
    // A run's peak: its set-up and settling (this process) or its timed steps
    // (the children), whichever is larger.
    double peak = settled_peak;
    for (const auto& r : s.runs) peak = std::max(peak, r["peak_rss_bytes"].get<double>());
    res.push_back({{"scene", l.name()},
                   {"threads", s.threads},
                   {"copies", s.copies},
                   {"placement", med["placement"]},
                   {"particles", med["particles"]},
                   {"particle_steps_per_second", rate},
                   {"min", rates[by.front()]},
                   {"max", rates[by.back()]},
                   {"rates", rates},
                   {"repeats", rounds},
                   {"speedup_vs_first", ratio},
                   {"speedup_vs_first_per_round", per_round},
                   {"seconds", med["seconds"]},
                   {"steps", med["steps"]},
                   {"neighbor_builds", med["neighbor_builds"]},
                   // the median round's (copies: the first run's)
                   {"breakdown", med["breakdown"]},
                   {"copy_rates", med.value("copy_rates", nlohmann::json::array())},
                   {"overlap", med.value("overlap", 1.0)},
                   // peak resident memory of a run (one simulation in the process), per particle
                   {"peak_rss_bytes_per_particle", peak / particles}});
    if (!as_json) {
      std::printf("scene %s  threads %d%s  %.3e particle-steps/s  (median of %d, range %.3e-%.3e; x%.2f, the "
                  "median round's ratio to the first)  peak memory %.0f bytes/particle\n",
                  l.name().c_str(), s.threads,
                  s.copies > 1 ? (" x " + std::to_string(s.copies) + " runs at once, summed").c_str() : "", rate,
                  rounds, rates[by.front()], rates[by.back()], ratio, peak / particles);
      if (s.copies == 1) std::printf("%s", med["timing"].get<std::string>().c_str());
    }
  }
  if (as_json) std::cout << res.dump(2) << "\n";
  return 0;
}

// The GPU engine's stepper for `granular bench`: K seeds of a drum or
// shaken-box scene (particles.seed + k), as a run starts them, with the
// steps of `settle` and of `length` (rotations of a drum, seconds of a box).
struct GpuBenchStepper {
  std::unique_ptr<gpu::DrumStepper> drum;
  std::unique_ptr<gpu::BoxStepper> box;
  long particles = 0, settle_steps = 0, steps = 0;
  void advance(long n) { drum ? drum->advance(n) : box->advance(n); }
  long builds() const { return drum ? drum->builds() : box->builds(); }
  const char* backend() const { return drum ? drum->backend() : box->backend(); }
};

GpuBenchStepper gpu_bench_stepper(const Loaded& l, const std::string& device, int replicas, double settle,
                                  double length, bool reorder) {
  GpuBenchStepper b;
  if (l.box) {
    const BoxScene& s = *l.box;
    std::vector<gpu::BoxModel> models;
    for (int k = 0; k < replicas; ++k) {
      BoxScene sk = s;
      sk.seed = s.seed + static_cast<std::uint64_t>(k);
      models.push_back(gpu::box_model(make_box(sk)));
      models.back().reorder = reorder;
    }
    check_device_memory(device, models);
    b.box = box_stepper_factory(device)(models);
    for (const auto& m : models) b.particles += static_cast<long>(m.p.size());
    b.settle_steps = std::lround((settle < 0 ? 1.0 : settle) / s.dt);
    b.steps = std::max(1L, std::lround(length / s.dt));
    return b;
  }
  const DrumScene& s = *l.drum;
  std::vector<gpu::DrumModel> models;
  for (int k = 0; k < replicas; ++k) {
    DrumScene sk = s;
    sk.seed = s.seed + static_cast<std::uint64_t>(k);
    DrumSim sim = make_drum(sk);
    if (k == 0) check_device_memory(device, sim, replicas);
    models.push_back(gpu::drum_model(sim));
    models.back().reorder = reorder;
  }
  b.drum = stepper_factory(device)(models);
  for (const auto& m : models) b.particles += static_cast<long>(m.p.size());
  b.settle_steps = s.steps_per(settle < 0 ? 0.5 : settle);
  b.steps = std::max(1L, s.steps_per(length));
  return b;
}

// granular bench --device gpu|gpu-host: the GPU engine's stepper on K seeds
// of a drum or shaken-box scene (particles.seed + k), settled `settle`
// rotations or seconds on the device, then `rounds` stretches of `length`
// rotations or seconds timed one after another; the median stretch is
// reported in the CPU bench's fields. memory_order: "cells" (the particles
// moved in memory to their cells' order at each list build, as a run does)
// or "ids" (kept in the order they were made, to measure what the order is
// worth).
int run_gpu_bench(const Loaded& l, const std::string& device, int replicas, int rounds, double settle,
                  double length, const std::string& memory_order, bool as_json) {
  GpuBenchStepper b = gpu_bench_stepper(l, device, replicas, settle, length, memory_order == "cells");
  GpuBenchStepper* const stepper = &b;
  const long particles = b.particles;
  stepper->advance(b.settle_steps);
  const long steps = b.steps;
  std::vector<double> rates, seconds;
  std::vector<long> builds;
  for (int k = 0; k < rounds; ++k) {
    const long b0 = stepper->builds();
    const auto t0 = std::chrono::steady_clock::now();
    stepper->advance(steps);
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    seconds.push_back(el);
    rates.push_back(el > 0 ? static_cast<double>(steps) * particles / el : 0.0);
    builds.push_back(stepper->builds() - b0);
  }
  std::vector<std::size_t> by(rates.size());
  for (std::size_t k = 0; k < by.size(); ++k) by[k] = k;
  std::sort(by.begin(), by.end(), [&](std::size_t a, std::size_t b) { return rates[a] < rates[b]; });
  const std::size_t med = by[by.size() / 2];
  const nlohmann::json res = nlohmann::json::array({{{"scene", l.name()},
                                                     {"device", device},
                                                     {"backend", stepper->backend()},
                                                     {"replicas", replicas},
                                                     {"memory_order", memory_order},
                                                     {"threads", device == "gpu-host" ? omp_get_max_threads() : 0},
                                                     {"copies", 1},
                                                     {"particles", particles},
                                                     {"particle_steps_per_second", rates[med]},
                                                     {"min", rates[by.front()]},
                                                     {"max", rates[by.back()]},
                                                     {"rates", rates},
                                                     {"repeats", rounds},
                                                     {"seconds", seconds[med]},
                                                     {"steps", steps},
                                                     {"neighbor_builds", builds[med]},
                                                     {"peak_rss_bytes_per_particle", peak_rss_bytes() / particles}}});
  if (as_json)
    std::cout << res.dump(2) << "\n";
  else
    std::printf("scene %s  device %s (%s)  %d replica(s), %ld particles, memory in %s order  %.3e "
                "particle-steps/s  (median of %d, range %.3e-%.3e)  %ld neighbour-list builds in %ld steps\n",
                l.name().c_str(), device.c_str(), stepper->backend(), replicas, particles, memory_order.c_str(),
                rates[med], rounds, rates[by.front()], rates[by.back()], builds[med], steps);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spin_briefly_before_sleeping(argv);  // may start the program again (app/openmp_wait.hpp)
  CLI::App app{"granular: discrete-element engine for the rotating drum (Rapaport 2002) and the shaken box "
               "(Poeschel and Herrmann 1995)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(kVersion));

  std::string scene_path, out_path;
  std::vector<std::string> sets;
  int threads = 0;
  bool force = false;
  auto* run = app.add_subcommand("run", "run a scene and write HDF5 output");
  run->add_option("scene", scene_path, "scene file (TOML)")->required();
  run->add_option("-o,--output", out_path, "output HDF5 file (default: the scene name + .h5)");
  auto* force_flag = run->add_flag("--force", force, "overwrite the output file if it exists");
  run->add_option("--set", sets, "override a scene key: key=value (repeatable)");
  run->add_option("--threads", threads, "OpenMP threads (default: all cores)")->check(CLI::PositiveNumber);
  RunOptions ro;
  run->add_flag("-q,--quiet", ro.quiet, "no progress line");
  auto* resume_flag = run->add_flag("--resume", ro.resume,
                                    "continue OUT from its checkpoint OUT.ckpt, appending to OUT (same scene and --set "
                                    "options; run.rotations or run.duration may grow)");
  run->add_option("--checkpoint-every", ro.checkpoint_minutes,
                  "minutes of wall-clock time between checkpoints (default 10; 0: only on SIGINT/SIGTERM and at the end)")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--checkpoint-steps", ro.checkpoint_steps, "also checkpoint every N steps")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--device", ro.device,
                  "cpu (default); gpu: the GPU engine on a CUDA device (a build with CUDA and a visible GPU); "
                  "gpu-host: the GPU engine's kernels run on the CPU, for checking it without a GPU (docs/gpu.md)")
      ->check(CLI::IsMember({"cpu", "gpu", "gpu-host"}));
  run->add_option("--replicas", ro.replicas,
                  "GPU engine: K drums of the scene with particles.seed, seed+1, ..., seed+K-1 side by side, each "
                  "written to OUT's stem + _r00, _r01, ... (docs/gpu.md)")
      ->check(CLI::PositiveNumber);

  resume_flag->excludes(force_flag);

  auto* init = app.add_subcommand("init", "write the initial state (one frame, masses, inertia) for another engine");
  init->add_option("scene", scene_path, "scene file (TOML)")->required();
  init->add_option("-o,--output", out_path, "output HDF5 file (default: the scene name + _init.h5)");
  init->add_flag("--force", force, "overwrite the output file if it exists");
  init->add_option("--set", sets, "override a scene key: key=value (repeatable)");

  bool as_json = false;
  auto* info = app.add_subcommand("info", "print the resolved scene and its particle count");
  info->add_option("scene", scene_path, "scene file (TOML)")->required();
  info->add_option("--set", sets, "override a scene key: key=value (repeatable)");
  info->add_flag("--json", as_json, "print JSON");

  std::vector<int> bench_threads;
  double settle = -1.0, bench_rot = 1.0, bench_seconds = 1.0;
  int repeat = 3;
  bool bench_json = false;
  auto* bench = app.add_subcommand("bench", "particle-steps per second for a scene");
  bench->add_option("scene", scene_path, "scene file (TOML)")->required();
  bench->add_option("--set", sets, "override a scene key: key=value (repeatable)");
  bench->add_option("--threads", bench_threads, "thread counts to measure (default: 1 and all cores)");
  bench->add_option("--settle", settle, "settling before timing: rotations (drum, default 0.5) or seconds (box, 1)");
  bench->add_option("--rotations", bench_rot, "drum: rotations timed");
  bench->add_option("--seconds", bench_seconds, "shaken box: seconds of shaking timed");
  bench->add_option("--repeat", repeat,
                    "rounds: each times every thread count once (and the ceiling), from the same settled state; "
                    "the median is reported")
      ->check(CLI::PositiveNumber);
  int ceiling = 0;
  bench->add_option("--ceiling", ceiling,
                    "also time N 1-thread runs at once each round, their rates summed: what N workers get on this "
                    "machine when nothing is shared but the machine (0: not timed)")
      ->check(CLI::NonNegativeNumber);
  bench->add_flag("--json", bench_json, "print JSON");
  std::string bench_device = "cpu";
  int bench_replicas = 0;
  bench->add_option("--device", bench_device,
                    "cpu (default), gpu or gpu-host: time the GPU engine's step instead (docs/gpu.md)")
      ->check(CLI::IsMember({"cpu", "gpu", "gpu-host"}));
  bench->add_option("--replicas", bench_replicas, "GPU engine: K seeds of the scene stepped side by side")
      ->check(CLI::PositiveNumber);
  std::string bench_memory_order = "cells";
  auto* memory_order_opt = bench->add_option("--gpu-memory-order", bench_memory_order,
                    "GPU engine: particles moved in memory to their cells' order at each list build (cells, as a run "
                    "does) or kept in the order they were made (ids)")
      ->check(CLI::IsMember({"cells", "ids"}));

  bool devices_json = false;
  auto* devices = app.add_subcommand("devices", "where --device can run: cpu, gpu-host, and gpu if a CUDA device is visible");
  devices->add_flag("--json", devices_json, "print JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help, --version: 0; a bad command line: 2
  }

  try {
    if (*devices) return print_devices(devices_json);
    if (*info) {
      const Loaded l = load(scene_path, sets);
      const auto j = info_json(l);
      if (as_json)
        std::cout << j.dump(2) << "\n";
      else
        std::cout << l.toml << "\n# particles: " << j["derived"]["particles"] << "\n";
      return 0;
    }
    if (*init) return init_scene(load(scene_path, sets), scene_path, out_path, force);
    if (*run) {
      if (threads > 0) omp_set_num_threads(threads);
      const Loaded l = load(scene_path, sets);  // all validation happens before the output is touched
      check_device(ro.device, ro.replicas, l);
      ro.sets = sets;
      ro.force = force;
      ro.threads_given = threads > 0;
      return run_scene(l, scene_path, out_path, ro);
    }
    if (*bench) {
      const Loaded l = load(scene_path, sets);
      if (l.particles) throw UsageError(scene_path + ": granular bench times drum and shaken-box scenes only");
      check_device(bench_device, bench_replicas, l);
      if (bench_device == "cpu" && memory_order_opt->count() > 0)
        throw UsageError("--gpu-memory-order: the GPU engine's memory order (--device gpu or gpu-host)");
      if (bench_device != "cpu")
        return run_gpu_bench(l, bench_device, std::max(1, bench_replicas), repeat, settle,
                             l.drum ? bench_rot : bench_seconds, bench_memory_order, bench_json);
      if (bench_threads.empty()) bench_threads = {1, omp_get_num_procs()};
      return run_bench(l, bench_threads, repeat, ceiling, settle, l.drum ? bench_rot : bench_seconds, bench_json);
    }
  } catch (const SceneError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const Interrupted& e) {
    std::fprintf(stderr, "\nstopped: %s\n", e.what());
    return 128 + e.signal();
  } catch (const UnstableError& e) {
    std::fprintf(stderr, "\nerror: %s\n(the output file keeps every frame written before this point)\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
