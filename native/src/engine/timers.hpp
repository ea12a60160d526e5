// Wall-clock time per phase of the step, printed in each run's summary.
#pragma once
#include <array>
#include <chrono>
#include <cstdio>
#include <sstream>
#include <string>

namespace granular {

enum class Phase { integrate, neighbor, pairs, walls, observe, count };

class PhaseTimers {
 public:
  using Clock = std::chrono::steady_clock;
  void add(Phase ph, Clock::duration d) { total_[static_cast<int>(ph)] += d; }
  double seconds(Phase ph) const {
    return std::chrono::duration<double>(total_[static_cast<int>(ph)]).count();
  }
  static const char* name(Phase ph) {
    static const char* names[] = {"integrate", "neighbor", "pairs", "walls", "observe"};
    return names[static_cast<int>(ph)];
  }
  void reset() {
    total_.fill(Clock::duration::zero());
    tails_taken = 0;
  }
  // Tail tasks run by a thread other than their block's owner (engine/simulation.hpp).
  long tails_taken = 0;

 private:
  std::array<Clock::duration, static_cast<int>(Phase::count)> total_{};
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

// Where the time of a run went, one line per phase, and the neighbour list's work.
// With `steps` > 0 it also sets the pair loop's time per contact beside a bare
// kernel's (Simulation::bare_kernel; contacts counted at the end of the run).
template <class Sim>
std::string phase_report(const Sim& sim, double total_seconds, long steps = 0) {
  std::ostringstream os;
  for (int k = 0; k < static_cast<int>(Phase::count); ++k) {
    const auto ph = static_cast<Phase>(k);
    char buf[128];
    std::snprintf(buf, sizeof buf, "  %-10s %8.2f s  %5.1f %%\n", PhaseTimers::name(ph), sim.timers.seconds(ph),
                  total_seconds > 0 ? 100.0 * sim.timers.seconds(ph) / total_seconds : 0.0);
    os << buf;
  }
  os << "  neighbour-list builds: " << sim.neighbors().builds() << ", pairs listed: " << sim.neighbors().n_pairs()
     << "\n";
  if (steps > 0 && sim.neighbors().tails() > 0) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "  tail tasks run by a thread other than their block's: %.2f a step (of %d)\n",
                  static_cast<double>(sim.timers.tails_taken) / static_cast<double>(steps),
                  sim.neighbors().tails() * sim.neighbors().threads());
    os << buf;
  }
  if (steps > 0) {
    const auto [contacts, bare_ns] = sim.bare_kernel();
    if (contacts > 0) {
      const double loop_ns = 1e9 * sim.timers.seconds(Phase::pairs) / (static_cast<double>(steps) * contacts);
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "  pair loop %.1f ns per contact (%zu contacts, %d thread(s)); bare kernel over a fixed "
                    "contact list %.1f ns (1 thread): x%.2f\n",
                    loop_ns, contacts, sim.neighbors().threads(), bare_ns, loop_ns / bare_ns);
      os << buf;
    }
  }
  return os.str();
}

}  // namespace granular
