// Checkpoints, interruption and resumption of a run, shared by the drum and
// the shaken box. The run loop calls Checkpointer::after_step at every step
// where may_act_at says it might write, and at every health check; it costs
// one clock read and one flag test unless a checkpoint is due.
#pragma once
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdint>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "engine/checkpoint.hpp"
#include "engine/timers.hpp"
#include "io/checkpoint_file.hpp"
#include "io/h5_output.hpp"

namespace granular {

struct RunControl {
  std::string checkpoint;        // checkpoint path; empty: no checkpoints
  double every_seconds = 600.0;  // wall-clock time between checkpoints (0: not by time)
  long every_steps = 0;          // steps between checkpoints (0: not by steps)
  const CheckpointData* resume = nullptr;  // continue from this state
  CheckpointData meta;           // run-level fields copied into each checkpoint
};

// SIGINT or SIGTERM arrived: the run wrote a checkpoint and stopped.
class Interrupted : public std::runtime_error {
 public:
  Interrupted(const std::string& what, int sig) : std::runtime_error(what), signal_(sig) {}
  int signal() const { return signal_; }

 private:
  int signal_;
};

// SIGINT/SIGTERM ask the run to stop at the end of its step (a second signal
// stops at once, without a checkpoint).
void install_stop_handlers();
int stop_signal();  // 0 if no stop was requested

// The run loop takes the steps between two things it has to do in one call
// (Simulation::advance: one parallel region between neighbour-list
// rebuilds). From step k at time t, the first step m in (k, last] for which
// acts(m, t_m) holds, or last; t_m is the time after step m, summed step by
// step as the simulation sums it (the same bits).
template <class Acts>
long next_stop(long k, double t, double dt, long last, Acts&& acts) {
  for (long m = k + 1;; ++m) {
    t += dt;
    if (m >= last || acts(m, t)) return m;
  }
}

// Before a run loop: the state and output counters from ctl.resume (put into
// sim by restore_from(checkpoint)), or else the run's first output. Returns
// the step the loop continues after.
template <class Sim, class FirstOutput, class Restore>
long begin_run(Sim& sim, const RunControl& ctl, std::initializer_list<long*> counters, const char* kind,
               FirstOutput first_output, Restore restore_from) {
  if (!ctl.resume) {
    first_output();
    return 0;
  }
  restore_from(*ctl.resume);
  if (ctl.resume->counters.size() != counters.size())
    throw std::runtime_error(ctl.checkpoint + ": not a " + kind + " checkpoint");
  auto saved = ctl.resume->counters.begin();
  for (long* c : counters) *c = *saved++;
  return sim.step_count;
}

// The same, restoring the simulation itself (engine/checkpoint.hpp, restore).
template <class Sim, class FirstOutput>
long begin_run(Sim& sim, const RunControl& ctl, std::initializer_list<long*> counters, const char* kind,
               FirstOutput first_output) {
  return begin_run(sim, ctl, counters, kind, first_output, [&](const CheckpointData& c) { restore(sim, c); });
}

struct RunReport {
  long steps = 0;
  long particles = 0;
  double seconds = 0.0;
  double particle_steps_per_second = 0.0;
  StepBreakdown breakdown;  // where the time went (engine/timers.hpp; format_breakdown prints it)
  long checkpoints = 0;  // checkpoints written
  long neighbor_builds = 0;  // neighbour-list builds in the timed steps (bench)
};

// Where a run's timed loop begins: the output opened to readers while it is
// written (SWMR) with its XDMF description from the start, the phase timers
// zeroed. Returns the loop's start time.
template <class Sim>
std::chrono::steady_clock::time_point start_loop(Sim& sim, H5Output* out) {
  if (out) {
    out->start_swmr();
    out->write_xdmf();  // from the start, the description beside the output is this run's
  }
  sim.timers.reset();
  return std::chrono::steady_clock::now();
}

// A run's loop, and where it ends: the XDMF description beside each output
// (io/xdmf.hpp) is rewritten at the last step and on the way out of an
// interruption (SIGINT, SIGTERM: Interrupted) or an instability
// (UnstableError); the progress line is closed.
template <class Loop>
void run_loop(const std::vector<H5Output*>& outs, bool progress, Loop&& loop) {
  try {
    loop();
  } catch (...) {
    for (H5Output* out : outs)
      if (out) out->write_xdmf();
    throw;
  }
  for (H5Output* out : outs)
    if (out) out->write_xdmf();
  if (progress) std::fprintf(stderr, "\n");
}
template <class Loop>
void run_loop(H5Output* out, bool progress, Loop&& loop) {
  run_loop(std::vector<H5Output*>{out}, progress, std::forward<Loop>(loop));
}

// The report of a run of `steps` steps begun at t0 (now ended).
template <class Sim>
RunReport run_report(const Sim& sim, long steps, std::chrono::steady_clock::time_point t0, long checkpoints = 0) {
  RunReport r;
  const long n = static_cast<long>(sim.p.size());
  r.steps = steps;
  r.particles = n;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.particle_steps_per_second = r.seconds > 0 ? static_cast<double>(r.steps) * n / r.seconds : 0.0;
  r.checkpoints = checkpoints;
  r.breakdown = step_breakdown(sim, r.seconds);
  return r;
}

class Checkpointer {
 public:
  explicit Checkpointer(const RunControl& ctl) : ctl_(ctl), last_(Clock::now()) {}

  // After a step (and its output). Writes a checkpoint when one is due, at the
  // final step, or when a stop was requested (then throws Interrupted).
  template <class Sim>
  void after_step(const Sim& sim, const H5Output* out, std::initializer_list<std::int64_t> counters, bool final_step) {
    after_step(sim, out, counters, final_step, [&](CheckpointData& c) { capture(sim, c); });
  }
  // The same, the state captured by capture_into(c) (a state held elsewhere:
  // the GPU path, gpu/stepper_driver.hpp).
  template <class Sim, class Capture>
  void after_step(const Sim& sim, const H5Output* out, std::initializer_list<std::int64_t> counters, bool final_step,
                  Capture capture_into) {
    const int sig = stop_signal();
    if (ctl_.checkpoint.empty()) {
      if (sig) throw Interrupted(interrupted_message(sim, sig, false), sig);
      return;
    }
    bool due = final_step || sig != 0 || (ctl_.every_steps > 0 && sim.step_count % ctl_.every_steps == 0);
    if (!due && ctl_.every_seconds > 0 && (sim.step_count & 63) == 0) {
      const auto now = Clock::now();
      due = std::chrono::duration<double>(now - last_).count() >= ctl_.every_seconds;
    }
    if (!due) return;
    CheckpointData c = ctl_.meta;
    capture_into(c);
    c.counters = counters;
    if (out) c.rows = out->rows();
    write_checkpoint(ctl_.checkpoint, c);
    last_ = Clock::now();
    ++written_;
    if (sig) throw Interrupted(interrupted_message(sim, sig, true), sig);
  }

  long written() const { return written_; }
  // Whether after_step may write a checkpoint after this step (a stop
  // signal aside, which it notices at the next step it is called after).
  bool may_act_at(long step) const {
    if (ctl_.checkpoint.empty()) return false;
    return (ctl_.every_steps > 0 && step % ctl_.every_steps == 0) || (ctl_.every_seconds > 0 && (step & 63) == 0);
  }

 private:
  using Clock = std::chrono::steady_clock;
  template <class Sim>
  std::string interrupted_message(const Sim& sim, int sig, bool saved) const {
    std::string m = std::string(sig == SIGINT ? "SIGINT" : "SIGTERM") + " at step " +
                    std::to_string(sim.step_count) + " (t = " + std::to_string(sim.time) + ")";
    if (saved) m += "; checkpoint written to " + ctl_.checkpoint + " (continue with --resume)";
    return m;
  }
  const RunControl& ctl_;
  Clock::time_point last_;
  long written_ = 0;
};

}  // namespace granular
