// The run loop that the drum's and the shaken box's runs share
// (engine/drum.cpp, engine/box.cpp): one simulation, or several members of one
// scene (replicas: other seeds) stepped by a driver (engine/run_driver.hpp),
// all on the first member's schedule. The scene's part of the loop is a
// RunPart (make_run_part):
//   kind               the checkpoint's kind ("drum", "shaken-box")
//   progress_every     steps between two progress lines at most
//   counters(r)        member r's two output counters, saved in its checkpoints
//   first_output(r)    member r's output before its first step (a new run)
//   observe(r, k)      member r's output after step k
//   acts(k, t)         whether step k (time t after it) observes
//   check(sim)         the health check of the first member's simulation
//   progress_line(sim, rate, seconds_left)   the progress line, on stderr
// Per step where it acts: the health check (every health.every steps and at
// the end), every member's output, every member's checkpoint (a stop signal
// ends the run once all have written theirs), the progress line.
#pragma once
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/health.hpp"
#include "engine/run_control.hpp"
#include "engine/run_driver.hpp"

namespace granular {

template <class Counters, class First, class Observe, class Acts, class Check, class Line>
struct RunPart {
  const char* kind;
  long progress_every;
  Counters counters;
  First first_output;
  Observe observe;
  Acts acts;
  Check check;
  Line progress_line;
};

template <class Counters, class First, class Observe, class Acts, class Check, class Line>
RunPart<Counters, First, Observe, Acts, Check, Line> make_run_part(const char* kind, long progress_every,
                                                                   Counters counters, First first_output,
                                                                   Observe observe, Acts acts, Check check,
                                                                   Line progress_line) {
  return {kind, progress_every, counters, first_output, observe, acts, check, progress_line};
}

// Steps every member from its start (step 0, or its checkpoint's step: the
// members' must agree) to step `total`.
template <class Sim, class Member, class Part>
RunReport run_members(std::vector<Member>& ms, const std::vector<Sim*>& sims, RunDriver* driver, bool progress,
                      long total, const HealthLimits& health, Part& part) {
  const std::size_t members = ms.size();
  Sim& sim = *sims.front();  // the schedule's
  long start = 0;
  for (std::size_t r = 0; r < members; ++r) {
    Sim& v = *sims[r];
    const std::array<long*, 2> c = part.counters(r);
    auto first_output = [&] { part.first_output(r); };
    const long from = driver ? begin_run(v, ms[r].ctl, {c[0], c[1]}, part.kind, first_output,
                                         [&](const CheckpointData& cp) { driver->restore(r, cp); })
                             : begin_run(v, ms[r].ctl, {c[0], c[1]}, part.kind, first_output);
    if (r == 0) start = from;
    if (from != start)
      throw std::runtime_error(ms[r].ctl.checkpoint + ": the members' checkpoints are of different steps");
  }
  if (driver) driver->start();
  std::vector<Checkpointer> checkpoints;
  for (const Member& m : ms) checkpoints.emplace_back(m.ctl);
  std::vector<H5Output*> outs;
  std::chrono::steady_clock::time_point t0;
  for (std::size_t r = 0; r < members; ++r) {
    outs.push_back(ms[r].out);
    t0 = start_loop(*sims[r], ms[r].out);
  }
  auto last_print = t0;
  long n = 0;
  for (Sim* v : sims) n += static_cast<long>(v->p.size());
  // The steps between two that observe, check, checkpoint or report run in one go.
  auto acts = [&](long k, double t) {
    return k % health.every == 0 || checkpoints.front().may_act_at(k) ||
           (progress && k % part.progress_every == 0) || part.acts(k, t);
  };
  // The XDMF description beside each output (io/xdmf.hpp) is rewritten after
  // each checkpoint and where the run ends: at its last step, on SIGINT or
  // SIGTERM (Interrupted), or when it stops unstable (UnstableError).
  run_loop(outs, progress, [&] {
    for (long k = start; k < total;) {
      const long next = next_stop(k, sim.time, sim.integrator.dt, total, acts);
      advance_run(driver, sim, next - k);
      k = next;
      const bool fin = k == total;
      if (k % health.every == 0 || fin) check_run_health(driver, health, [&] { part.check(sim); });
      for (std::size_t r = 0; r < members; ++r) part.observe(r, k);
      // Every member checkpoints before a stop signal ends the run.
      std::optional<Interrupted> stop;
      for (std::size_t r = 0; r < members; ++r) {
        const Sim& v = *sims[r];
        H5Output* out = ms[r].out;
        const long saved = checkpoints[r].written();
        const std::array<long*, 2> c = part.counters(r);
        try {
          if (driver)
            checkpoints[r].after_step(v, out, {*c[0], *c[1]}, fin,
                                      [&](CheckpointData& cp) { driver->capture(r, cp); });
          else
            checkpoints[r].after_step(v, out, {*c[0], *c[1]}, fin);
        } catch (const Interrupted& e) {
          if (!stop) stop = e;
        }
        if (out && checkpoints[r].written() != saved && !fin) out->write_xdmf();  // current with the checkpoint
      }
      if (stop) throw *stop;
      if (progress && (k % part.progress_every == 0 || fin)) {
        const auto now = std::chrono::steady_clock::now();
        if (now - last_print > std::chrono::milliseconds(500) || fin) {
          last_print = now;
          const double el = std::chrono::duration<double>(now - t0).count();
          const double rate = el > 0 ? static_cast<double>(k - start) * n / el : 0.0;
          part.progress_line(sim, rate, el / (k - start) * (total - k));
          std::fflush(stderr);
        }
      }
    }
  });
  long written = 0;
  for (const Checkpointer& c : checkpoints) written += c.written();
  RunReport r = run_report(sim, std::max(0L, total - start), t0, written);
  r.particles = n;
  r.particle_steps_per_second = r.seconds > 0 ? static_cast<double>(r.steps) * n / r.seconds : 0.0;
  return r;
}

}  // namespace granular
