// granular: the native engine's command-line program.
//   granular run SCENE [-o OUT.h5] [--set key=value]... [--threads N]
//   granular info SCENE [--set key=value]... [--json]
//   granular bench SCENE [--threads N]... [--settle R] [--rotations R]
#include <omp.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <algorithm>
#include <iostream>
#include <nlohmann/json.hpp>

#include "engine/drum.hpp"
#include "scene/scene_file.hpp"
#include "version.hpp"

using namespace granular;

namespace {

struct Loaded {
  DrumScene scene;
  std::string toml, json;
};

Loaded load(const std::string& path, const std::vector<std::string>& sets) {
  if (!std::filesystem::exists(path)) throw SceneError(path, "no such scene file");
  SceneFile f(path, sets);
  Loaded l{read_drum_scene(f), "", ""};
  l.toml = f.resolved_toml();
  l.json = f.resolved_json();
  return l;
}

nlohmann::json info_json(const Loaded& l, const ParticleStore<3>& p) {
  auto j = nlohmann::json::parse(l.json);
  long n_small = 0;
  for (auto sp : p.species) n_small += sp == 0;
  nlohmann::json d;
  d["particles"] = p.size();
  d["particles_small"] = n_small;
  d["particles_big"] = static_cast<long>(p.size()) - n_small;
  if (l.scene.paper_n > 0) {
    d["paper_particles"] = l.scene.paper_n;
    d["particles_vs_paper_percent"] = 100.0 * (static_cast<double>(p.size()) / l.scene.paper_n - 1.0);
  }
  d["rotation_period"] = l.scene.rotation_period();
  d["steps_per_rotation"] = l.scene.rotation_period() / l.scene.dt;
  d["steps_total"] = l.scene.steps_per(l.scene.rotations);
  j["derived"] = d;
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"granular: discrete-element engine for the rotating drum (Rapaport 2002) and the shaken box"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(kVersion));

  std::string scene_path, out_path;
  std::vector<std::string> sets;
  int threads = 0;
  auto* run = app.add_subcommand("run", "run a scene and write HDF5 output");
  run->add_option("scene", scene_path, "scene file (TOML)")->required();
  run->add_option("-o,--output", out_path, "output HDF5 file (default: the scene name + .h5)");
  run->add_option("--set", sets, "override a scene key: key=value (repeatable)");
  run->add_option("--threads", threads, "OpenMP threads (default: all cores)")->check(CLI::PositiveNumber);
  bool quiet = false;
  run->add_flag("-q,--quiet", quiet, "no progress line");

  bool as_json = false;
  auto* info = app.add_subcommand("info", "print the resolved scene and its particle count");
  info->add_option("scene", scene_path, "scene file (TOML)")->required();
  info->add_option("--set", sets, "override a scene key: key=value (repeatable)");
  info->add_flag("--json", as_json, "print JSON");

  std::vector<int> bench_threads;
  double settle = 0.5, bench_rot = 1.0;
  auto* bench = app.add_subcommand("bench", "particle-steps per second for a drum scene");
  bench->add_option("scene", scene_path, "scene file (TOML)")->required();
  bench->add_option("--set", sets, "override a scene key: key=value (repeatable)");
  bench->add_option("--threads", bench_threads, "thread counts to measure (default: 1 and all cores)");
  bench->add_option("--settle", settle, "rotations run before timing");
  bench->add_option("--rotations", bench_rot, "rotations timed");
  int repeat = 3;
  bench->add_option("--repeat", repeat, "repetitions per thread count; the median is reported")
      ->check(CLI::PositiveNumber);
  bool bench_json = false;
  bench->add_flag("--json", bench_json, "print JSON");

  CLI11_PARSE(app, argc, argv);

  try {
    if (*info) {
      const Loaded l = load(scene_path, sets);
      const auto p = drum_particles(l.scene);
      const auto j = info_json(l, p);
      if (as_json)
        std::cout << j.dump(2) << "\n";
      else
        std::cout << l.toml << "\n# particles: " << p.size() << " (paper: " << l.scene.paper_n << ")\n";
      return 0;
    }
    if (*run) {
      if (threads > 0) omp_set_num_threads(threads);
      const Loaded l = load(scene_path, sets);  // all validation happens before the output is touched
      if (out_path.empty()) out_path = l.scene.name + ".h5";
      DrumSim sim = make_drum(l.scene);
      const auto n = std::visit([](auto& s) { return s.p.size(); }, sim);
      H5Output out(out_path, 3, static_cast<std::int64_t>(n));
      out.attr("engine", std::string("granular-native"));
      out.attr("engine_version", std::string(kVersion));
      out.attr("scene_kind", std::string("drum"));
      out.attr("scene_name", l.scene.name);
      out.attr("scene_file", scene_path);
      out.attr("scene_toml", l.toml);
      out.attr("scene_json", l.json);
      out.attr("omega", l.scene.omega);
      out.attr("rotation_period", l.scene.rotation_period());
      out.attr("threads", static_cast<std::int64_t>(omp_get_max_threads()));
      out.group_attr("frames", "species_names", {"small", "big"});
      std::fprintf(stderr, "granular %s: scene %s (%s), %zu particles, %.4g rotations, %d thread(s) -> %s\n",
                   kVersion, l.scene.name.c_str(), scene_path.c_str(), n, l.scene.rotations, omp_get_max_threads(),
                   out_path.c_str());
      const bool progress = !quiet && isatty(fileno(stderr));
      const RunReport r = run_drum(l.scene, sim, &out, progress);
      std::fprintf(stderr, "done: %ld steps in %.1f s, %.3g particle-steps/s\n%s", r.steps, r.seconds,
                   r.particle_steps_per_second, r.timing.c_str());
      return 0;
    }
    if (*bench) {
      const Loaded l = load(scene_path, sets);
      if (bench_threads.empty()) bench_threads = {1, omp_get_num_procs()};
      nlohmann::json res = nlohmann::json::array();
      double base = 0.0;
      for (int t : bench_threads) {
        omp_set_num_threads(t);
        // The machine is shared: repeat and report the median, with the spread.
        std::vector<RunReport> reps;
        for (int k = 0; k < repeat; ++k) reps.push_back(bench_drum(l.scene, settle, bench_rot));
        std::sort(reps.begin(), reps.end(), [](const RunReport& a, const RunReport& b) {
          return a.particle_steps_per_second < b.particle_steps_per_second;
        });
        const RunReport& r = reps[reps.size() / 2];
        if (base == 0.0) base = r.particle_steps_per_second;
        res.push_back({{"scene", l.scene.name},
                       {"threads", t},
                       {"particles", r.particles},
                       {"particle_steps_per_second", r.particle_steps_per_second},
                       {"min", reps.front().particle_steps_per_second},
                       {"max", reps.back().particle_steps_per_second},
                       {"repeats", repeat},
                       {"speedup_vs_first", r.particle_steps_per_second / base},
                       {"seconds", r.seconds},
                       {"steps", r.steps}});
        if (!bench_json)
          std::printf("scene %s  threads %d  %.3e particle-steps/s  (median of %d, range %.3e-%.3e; x%.2f)\n%s",
                      l.scene.name.c_str(), t, r.particle_steps_per_second, repeat,
                      reps.front().particle_steps_per_second, reps.back().particle_steps_per_second,
                      r.particle_steps_per_second / base, r.timing.c_str());
      }
      if (bench_json) std::cout << res.dump(2) << "\n";
      return 0;
    }
  } catch (const SceneError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const UnstableError& e) {
    std::fprintf(stderr, "\nerror: %s\n(the output file keeps every frame written before this point)\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
