// Whether a thread that has finished its block takes the other blocks' tail
// tasks (engine/parallel/tail_tasks.hpp), chosen by timing both.
//
// Taking them evens the threads out when one core runs slower for a while
// (10-27 % on the box; docs/speed_accuracy.md, "Tail tasks"). But a task taken
// reads the owner's particles and writes its buffer, and the owner then adds
// the buffer and moves those particles: every such cache line crosses
// between the cores twice a step. When the host makes that dear (its slow
// state), taking tasks costs more than it saves: box 3 Hz, 2
// threads, 3.3-3.4 against 4.1-4.7·10^7 particle-steps/s without. Which one
// wins changes with the host's state, for seconds at a time, so the engine
// times both: a window with, a window without, then kExploit windows of the
// faster, then both again. A task's entries are summed in a fixed order
// whoever ran it, so the trajectory is the same bits either way: only the
// speed changes.
#pragma once
#include <chrono>

namespace granular {

class StealChoice {
 public:
  using Clock = std::chrono::steady_clock;
  // A window: at least this much wall time (a box step lasts some 20 µs,
  // a drum #A step some 300 µs on two threads).
  static constexpr double kWindowSeconds = 0.02;
  // Windows of the faster choice between two timings.
  static constexpr int kExploit = 8;

  bool steal() const { return steal_; }

  // Takes them always (true) or never, untimed: for tests that need one or
  // the other.
  void fix(bool steal) {
    steal_ = steal;
    fixed_ = true;
  }

  // After `steps` steps on two or more threads that took `d` (wall time).
  // Returns whether that closed a window.
  bool record(long steps, Clock::duration d) {
    if (fixed_) return false;
    steps_ += steps;
    seconds_ += std::chrono::duration<double>(d).count();
    if (seconds_ < kWindowSeconds || steps_ <= 0) return false;
    const double per_step = seconds_ / static_cast<double>(steps_);
    steps_ = 0;
    seconds_ = 0.0;
    if (phase_ == 0) {  // timed with stealing; now without
      with_ = per_step;
      steal_ = false;
      phase_ = 1;
    } else if (phase_ == 1) {  // timed without (per_step); keep the faster
      steal_ = with_ <= per_step;
      phase_ = 2;
    } else if (++phase_ == 2 + kExploit) {
      steal_ = true;
      phase_ = 0;
    }
    return true;
  }

 private:
  bool steal_ = true;
  bool fixed_ = false;
  int phase_ = 0;  // 0: timing with, 1: timing without, 2..: the faster
  long steps_ = 0;
  double seconds_ = 0.0;
  double with_ = 0.0;  // seconds per step with stealing, in the last timing
};

}  // namespace granular
