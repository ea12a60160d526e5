// Wall-clock time per phase of the step, printed in each run's summary.
#pragma once
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <sstream>
#include <string>

#include "engine/bare_kernel.hpp"

namespace granular {

enum class Phase { integrate, neighbor, pairs, walls, observe, count };

class PhaseTimers {
 public:
  using Clock = std::chrono::steady_clock;
  void add(Phase ph, Clock::duration d) { total_[static_cast<int>(ph)] += d; }
  double seconds(Phase ph) const { return std::chrono::duration<double>(total_[static_cast<int>(ph)]).count(); }
  static const char* name(Phase ph) {
    static const char* names[] = {"integrate", "neighbor", "pairs", "walls", "observe"};
    return names[static_cast<int>(ph)];
  }
  void reset() {
    total_.fill(Clock::duration::zero());
    tails_taken = 0;
    steal_windows = steal_windows_stealing = 0;
  }
  // Tail tasks run by a thread other than their block's owner (engine/parallel/tail_tasks.hpp).
  long tails_taken = 0;
  // Windows timed for the choice to take them (engine/steal_choice.hpp), and
  // those in which they were taken.
  long steal_windows = 0, steal_windows_stealing = 0;

 private:
  std::array<Clock::duration, static_cast<int>(Phase::count)> total_{};
};

// One thread's stopwatch over the phases of its steps: each lap adds the
// time since the last to the phase it names. The sums stay in the stopwatch
// (on the thread's stack, not on a line the other threads read) until
// add_to(). A stopwatch that is off reads no clock: in a parallel region only
// the master's runs, and its laps are the step's figures.
class PhaseLaps {
 public:
  explicit PhaseLaps(bool on) : on_(on), last_(on ? PhaseTimers::Clock::now() : PhaseTimers::Clock::time_point{}) {}
  void lap(Phase ph) {
    if (!on_) return;
    const auto now = PhaseTimers::Clock::now();
    sums_[static_cast<int>(ph)] += now - last_;
    last_ = now;
  }
  void add_to(PhaseTimers& timers) const {
    if (!on_) return;
    for (int k = 0; k < static_cast<int>(Phase::count); ++k) timers.add(static_cast<Phase>(k), sums_[k]);
  }

 private:
  bool on_;
  PhaseTimers::Clock::time_point last_;
  std::array<PhaseTimers::Clock::duration, static_cast<int>(Phase::count)> sums_{};
};

class ScopedPhase {
 public:
  ScopedPhase(PhaseTimers& t, Phase ph) : t_(t), ph_(ph), start_(PhaseTimers::Clock::now()) {}
  ~ScopedPhase() { t_.add(ph_, PhaseTimers::Clock::now() - start_); }

 private:
  PhaseTimers& t_;
  Phase ph_;
  PhaseTimers::Clock::time_point start_;
};

// Where the time of a run went: seconds per phase, the neighbour list's work
// and, for a timed stretch (bench), the pair loop beside a bare kernel over a
// fixed contact list (engine/bare_kernel.hpp; contacts counted at the end).
struct StepBreakdown {
  std::array<double, static_cast<int>(Phase::count)> seconds{};
  double total_seconds = 0.0;
  long steps = 0;   // 0: the run's summary (no per-step figures)
  long builds = 0;  // neighbour-list builds
  std::size_t pairs_listed = 0;
  int threads = 1;
  int tail_tasks = 0;                 // tail tasks a step (0 on one thread)
  double tails_taken_per_step = 0.0;  // of those, run by a thread other than their block's
  long steal_windows = 0;             // windows timed for the choice to take them (engine/steal_choice.hpp)
  long steal_windows_stealing = 0;    // of those, with the tasks taken
  std::size_t contacts = 0;           // 0: no pair-loop figures
  double pair_loop_ns = 0.0;          // the pairs phase per step and contact
  double bare_kernel_ns = 0.0;        // one contact through the law's pair_force, 1 thread
};

template <class Sim>
StepBreakdown step_breakdown(const Sim& sim, double total_seconds, long steps = 0) {
  StepBreakdown b;
  for (int k = 0; k < static_cast<int>(Phase::count); ++k) b.seconds[k] = sim.timers.seconds(static_cast<Phase>(k));
  b.total_seconds = total_seconds;
  b.steps = steps;
  b.builds = sim.neighbors().builds();
  b.pairs_listed = sim.neighbors().n_pairs();
  b.threads = sim.neighbors().threads();
  b.tail_tasks = sim.neighbors().tails() * b.threads;
  if (steps > 0) {
    b.tails_taken_per_step = static_cast<double>(sim.timers.tails_taken) / static_cast<double>(steps);
    b.steal_windows = sim.timers.steal_windows;
    b.steal_windows_stealing = sim.timers.steal_windows_stealing;
    const auto [contacts, bare_ns] = bare_kernel(sim);
    if (contacts > 0) {
      b.contacts = contacts;
      b.pair_loop_ns = 1e9 * b.seconds[static_cast<int>(Phase::pairs)] / (static_cast<double>(steps) * contacts);
      b.bare_kernel_ns = bare_ns;
    }
  }
  return b;
}

// The breakdown, one line per phase, as a run's summary prints it.
inline std::string format_breakdown(const StepBreakdown& b) {
  std::ostringstream os;
  for (int k = 0; k < static_cast<int>(Phase::count); ++k) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "  %-10s %8.2f s  %5.1f %%\n", PhaseTimers::name(static_cast<Phase>(k)),
                  b.seconds[k], b.total_seconds > 0 ? 100.0 * b.seconds[k] / b.total_seconds : 0.0);
    os << buf;
  }
  os << "  neighbour-list builds: " << b.builds << ", pairs listed: " << b.pairs_listed << "\n";
  if (b.steps > 0 && b.tail_tasks > 0) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "  tail tasks run by a thread other than their block's: %.2f a step (of %d); taken in %ld of %ld "
                  "timed windows\n",
                  b.tails_taken_per_step, b.tail_tasks, b.steal_windows_stealing, b.steal_windows);
    os << buf;
  }
  if (b.contacts > 0) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "  pair loop %.1f ns per contact (%zu contacts, %d thread(s)); bare kernel over a fixed "
                  "contact list %.1f ns (1 thread): x%.2f\n",
                  b.pair_loop_ns, b.contacts, b.threads, b.bare_kernel_ns, b.pair_loop_ns / b.bare_kernel_ns);
    os << buf;
  }
  return os.str();
}

}  // namespace granular
