// Wall-clock time per phase of the step, printed in each run's summary.
#pragma once
#include <array>
#include <chrono>
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
  void reset() { total_.fill(Clock::duration::zero()); }

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

}  // namespace granular
