// Where the engine's OpenMP threads run.
//
// Threads left to the kernel's scheduler move between cores, and a thread
// that moves leaves its block's columns in another core's cache. On a
// 16-core machine, #T (62 244 particles) at 16 threads ran 2.05 times as fast
// as one thread with the threads free to move, and 4.9 times with each bound
// to a core (OMP_PROC_BIND=close, OMP_PLACES=cores; docs/speed_accuracy.md,
// "Where the threads run").
//
// So a run whose team fills the CPUs the process may use (its affinity mask:
// a cgroup's or taskset's limits count) binds its threads itself, thread t to
// the t-th core of the mask in the order of the CPU numbers (close), one
// thread a core (all of that core's logical CPUs), or one a logical CPU when
// the team has a thread for each. A smaller team is left free: other runs may
// share the machine (a campaign of one-thread runs, one per core), and bound
// threads of two runs could pile onto the same cores. Where the environment
// places the threads itself (OMP_PROC_BIND, OMP_PLACES or GOMP_CPU_AFFINITY
// set, e.g. OMP_PROC_BIND=false to keep them free), the program does nothing.
#pragma once
#include <omp.h>
#include <pthread.h>
#include <sched.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace granular {

// The CPUs of this process's affinity mask grouped by core (the logical CPUs
// that share one: /sys's thread_siblings_list), the cores in the order of
// their first CPU; each CPU its own core where /sys does not say.
inline std::vector<std::vector<int>> cores_of_mask() {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (sched_getaffinity(0, sizeof mask, &mask) != 0) return {};
  std::map<std::string, std::vector<int>> by_siblings;
  std::vector<std::string> order;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (!CPU_ISSET(c, &mask)) continue;
    std::string key;
    std::ifstream f("/sys/devices/system/cpu/cpu" + std::to_string(c) + "/topology/thread_siblings_list");
    if (!std::getline(f, key) || key.empty()) key = "cpu" + std::to_string(c);
    auto [it, fresh] = by_siblings.try_emplace(key);
    if (fresh) order.push_back(key);
    it->second.push_back(c);
  }
  std::vector<std::vector<int>> out;
  for (const std::string& k : order) out.push_back(by_siblings[k]);
  return out;
}

// How a team of `threads` is placed on `cores` (cores_of_mask()): each thread's
// CPUs, or nothing when the team is left free (it fills neither every core
// nor every logical CPU).
inline std::vector<std::vector<int>> placement(int threads, const std::vector<std::vector<int>>& cores) {
  std::vector<int> logical;
  for (const auto& core : cores) logical.insert(logical.end(), core.begin(), core.end());
  std::vector<std::vector<int>> out;
  if (threads < 2) return out;
  if (static_cast<std::size_t>(threads) == cores.size()) return cores;
  if (static_cast<std::size_t>(threads) == logical.size())
    for (const int c : logical) out.push_back({c});
  return out;
}

// Binds the threads of the current team size (omp_get_max_threads()) as the
// header says; returns "cores", "cpus" (one thread a logical CPU) or "free".
inline const char* place_threads() {
  for (const char* v : {"OMP_PROC_BIND", "OMP_PLACES", "GOMP_CPU_AFFINITY"})
    if (std::getenv(v) != nullptr) return "free";
  const auto cores = cores_of_mask();
  const int nt = omp_get_max_threads();
  const auto where = placement(nt, cores);
  if (where.empty()) return "free";
#pragma omp parallel num_threads(nt)
  {
    cpu_set_t set;
    CPU_ZERO(&set);
    for (const int c : where[static_cast<std::size_t>(omp_get_thread_num())]) CPU_SET(c, &set);
    pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  }
  return where.front().size() > 1 || static_cast<std::size_t>(nt) == cores.size() ? "cores" : "cpus";
}

}  // namespace granular
