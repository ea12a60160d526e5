// How much two threads of one process can gain on this machine, for a loop
// shaped like the engine's step, with no physics in it (docs/speed_accuracy.md):
//   thread_probe [--particles N] [--steps S] [--rounds R] [--halo-lines L] [--ghost-lines G] > probe.json
// The work is a stand-in for the integration: each of N particles updates 10
// double columns per step. Measured, in interleaved rounds (medians):
//   - one thread on N/2 particles, the process alone;
//   - the same, as two processes at once (they share nothing but the machine:
//     the ceiling `compare bench` also measures), each one's time and the
//     slower one's (two threads finish when the slower one does);
//   - two threads of one process, each on its own half of N, never meeting;
//   - the same with one OpenMP barrier per step (the engine's step has two
//     barriers and a fork and join);
//   - the same with the engine's two meetings per step instead, alone and
//     with a halo of L lines one way and G lines back each step (halo());
//   - the round trip of a cache line between the two threads.
// Two threads "never meeting" share only the process: when they run slower
// than two processes, the loss is the machine's, not any program's
// synchronisation.
#include <omp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "app/openmp_wait.hpp"
#include "core/doorbell.hpp"
#include "core/threads.hpp"

namespace {

using Clock = std::chrono::steady_clock;

// The threads' shares of a column are kGap doubles apart: with shares that
// touch, a thread streaming to the end of its share has the hardware prefetch
// the first lines of the next share, which the other thread is writing, and
// that costs this loop 1.2-1.9 times (tested with gaps of 0, 16, 64-512
// doubles: 64 removes it). The engine's blocks touch; reversing one thread's
// sweeps there changed nothing (docs/speed_accuracy.md, "The threads' blocks").
constexpr std::size_t kGap = 128;

// One step's work on particles [a, e) of the columns c.
inline void work(const std::vector<double*>& c, std::size_t a, std::size_t e) {
  for (std::size_t i = a; i < e; ++i) {
    const double x = c[0][i] * 0.5 + c[1][i];
    c[2][i] += x * c[3][i];
    c[4][i] = c[5][i] + c[2][i] * 1e-3;
    c[6][i] += c[7][i] * c[8][i];
    c[9][i] = x;
  }
}

// Microseconds per step of `threads` threads, each on its own share of n
// particles (kGap apart); a barrier per step if `meet`.
double stream(std::size_t n, long steps, int threads, bool meet) {
  constexpr int kColumns = 10;
  std::vector<std::vector<double>> col(kColumns, std::vector<double>(n + kGap * static_cast<std::size_t>(threads), 1.0));
  std::vector<double*> c(kColumns);
  for (int k = 0; k < kColumns; ++k) c[k] = col[k].data();
  const auto t0 = Clock::now();
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    const auto [share_lo, share_hi] = granular::thread_block(n, threads, t);
    const std::size_t gap = kGap * static_cast<std::size_t>(t), lo = share_lo + gap, hi = share_hi + gap;
    for (long s = 0; s < steps; ++s) {
      work(c, lo, hi);
      if (meet) {
#pragma omp barrier
      }
    }
  }
  const double us = 1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / static_cast<double>(steps);
  volatile double sink = c[9][0];
  (void)sink;
  return us;
}

// Microseconds per step of two threads on n particles that meet twice a step
// and exchange a halo, as the engine's two threads do (engine/simulation.hpp):
// thread 1 writes `out` cache lines before the step's first meeting (the
// moved positions and velocities of its particles that thread 0's rows
// read), thread 0 reads them after it and writes `back` lines (its ghost
// forces for those particles), which thread 1 reads after the second
// meeting. Each half's pass is split in two around the first meeting. With
// no lines this is the two meetings alone. The shaken box at 3 Hz exchanges
// about 36 lines one way and 25 the other (docs/speed_accuracy.md, "The threads' blocks").
double halo(std::size_t n, long steps, std::size_t out, std::size_t back) {
  constexpr int kColumns = 10;
  constexpr std::size_t kLine = 8;  // doubles
  std::vector<std::vector<double>> col(kColumns, std::vector<double>(n + 2 * kGap, 1.0));
  std::vector<double*> c(kColumns);
  for (int k = 0; k < kColumns; ++k) c[k] = col[k].data();
  struct alignas(64) Flag {
    std::atomic<long> seq{0}, met{0};
    granular::Doorbell bell;
  };
  std::vector<Flag> flag(2);
  std::vector<double> h_out(out * kLine + kLine, 1.0), h_back(back * kLine + kLine, 1.0);
  const auto t0 = Clock::now();
#pragma omp parallel num_threads(2)
  {
    const int t = omp_get_thread_num(), u = 1 - t;
    const auto [share_lo, share_hi] = granular::thread_block(n, 2, t);
    const std::size_t gap = kGap * static_cast<std::size_t>(t), lo = share_lo + gap, hi = share_hi + gap;
    const std::size_t mid = lo + (hi - lo) / 2;
    double carry = 0.0;
    for (long s = 1; s <= steps; ++s) {
      if (t == 1)
        for (std::size_t k = 0; k < out * kLine; ++k) h_out[k] = carry + static_cast<double>(k);
      work(c, lo, mid);
      flag[t].seq.store(s, std::memory_order_release);
      flag[t].bell.ring();
      flag[u].bell.wait_until([&] { return flag[u].seq.load(std::memory_order_acquire) >= s; });
      if (t == 0) {
        double sum = 0.0;
        for (std::size_t k = 0; k < out * kLine; ++k) sum += h_out[k];
        for (std::size_t k = 0; k < back * kLine; ++k) h_back[k] = sum + static_cast<double>(k);
      }
      work(c, mid, hi);
      flag[t].met.store(s, std::memory_order_release);
      flag[t].bell.ring();
      flag[u].bell.wait_until([&] { return flag[u].met.load(std::memory_order_acquire) >= s; });
      if (t == 1)
        for (std::size_t k = 0; k < back * kLine; ++k) carry += h_back[k];
    }
    if (t == 1) c[9][lo] += carry * 1e-300;
  }
  const double us = 1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / static_cast<double>(steps);
  volatile double sink = c[9][0];
  (void)sink;
  return us;
}

// Two processes at once, each one thread on m particles: each one's time.
std::vector<double> two_processes(std::size_t m, long steps) {
  int fd[2][2];
  pid_t pid[2];
  for (int k = 0; k < 2; ++k) {
    if (pipe(fd[k]) != 0) throw std::runtime_error("thread_probe: pipe failed");
    pid[k] = fork();
    if (pid[k] < 0) throw std::runtime_error("thread_probe: fork failed");
    if (pid[k] == 0) {
      const double us = stream(m, steps, 1, false);
      if (write(fd[k][1], &us, sizeof us) != sizeof us) _exit(1);
      _exit(0);
    }
    close(fd[k][1]);
  }
  std::vector<double> out;
  for (int k = 0; k < 2; ++k) {
    double us = 0.0;
    const bool ok = read(fd[k][0], &us, sizeof us) == sizeof us;
    close(fd[k][0]);
    int status = 0;
    waitpid(pid[k], &status, 0);
    if (!ok || status != 0) throw std::runtime_error("thread_probe: a probe process failed");
    out.push_back(us);
  }
  return out;
}

// Nanoseconds for a cache line to go to the other thread and back, each
// side waiting as the engine's threads wait for each other (core/doorbell.hpp:
// spinning, then sleeping if the other thread is not running).
double round_trip_ns(long trips = 200000) {
  alignas(64) std::atomic<long> flag{0};
  granular::Doorbell bell;
  const auto wait_for = [&](long want) {
    bell.wait_until([&] { return flag.load(std::memory_order_acquire) == want; });
  };
  std::thread other([&] {
    for (long i = 0; i < trips; ++i) {
      wait_for(2 * i + 1);
      flag.store(2 * i + 2, std::memory_order_release);
      bell.ring();
    }
  });
  const auto t0 = Clock::now();
  for (long i = 0; i < trips; ++i) {
    flag.store(2 * i + 1, std::memory_order_release);
    bell.ring();
    wait_for(2 * i + 2);
  }
  other.join();
  return 1e9 * std::chrono::duration<double>(Clock::now() - t0).count() / static_cast<double>(trips);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t k = v.size() / 2;
  return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
}

}  // namespace

int main(int argc, char** argv) {
  granular::spin_briefly_before_sleeping(argv);  // wait as the engine does (app/openmp_wait.hpp)
  CLI::App app{"two threads against two processes, on a loop shaped like the step"};
  std::size_t n = 8000;
  long steps = 20000;
  int rounds = 8;
  std::size_t out_lines = 36, back_lines = 25;
  app.add_option("--particles", n, "particles of the whole loop (each thread or process gets half)")
      ->check(CLI::Range(std::size_t{2}, std::size_t{1} << 28));
  app.add_option("--steps", steps, "steps per measurement")->check(CLI::PositiveNumber);
  app.add_option("--rounds", rounds, "interleaved rounds (medians reported)")->check(CLI::PositiveNumber);
  app.add_option("--halo-lines", out_lines, "cache lines thread 1 writes and thread 0 reads each step")
      ->check(CLI::Range(std::size_t{0}, std::size_t{1} << 20));
  app.add_option("--ghost-lines", back_lines, "cache lines thread 0 writes and thread 1 reads each step")
      ->check(CLI::Range(std::size_t{0}, std::size_t{1} << 20));
  CLI11_PARSE(app, argc, argv);
  try {
    std::vector<double> alone, procs, slower, apart, meeting, two_meetings, with_halo, trip;
    for (int r = 0; r < rounds; ++r) {
      alone.push_back(stream(n / 2, steps, 1, false));
      const auto both = two_processes(n / 2, steps);
      procs.insert(procs.end(), both.begin(), both.end());
      slower.push_back(std::max(both[0], both[1]));
      apart.push_back(stream(n, steps, 2, false));
      meeting.push_back(stream(n, steps, 2, true));
      two_meetings.push_back(halo(n, steps, 0, 0));
      with_halo.push_back(halo(n, steps, out_lines, back_lines));
      trip.push_back(round_trip_ns());
    }
    const double a = median(alone);
    nlohmann::json j;
    j["particles"] = n;
    j["steps"] = steps;
    j["rounds"] = rounds;
    j["halo_lines"] = out_lines;
    j["ghost_lines"] = back_lines;
    j["us_per_step"] = {{"one_thread_half_alone", a},
                        {"two_processes_half_each", median(procs)},
                        {"two_processes_slower_one", median(slower)},
                        {"two_threads_apart", median(apart)},
                        {"two_threads_one_barrier_per_step", median(meeting)},
                        {"two_threads_two_meetings_per_step", median(two_meetings)},
                        {"two_threads_two_meetings_and_halo", median(with_halo)}};
    // Speed-ups over one thread doing all the work (twice the half's time).
    j["speedup"] = {{"two_processes", 2.0 * a / median(procs)},
                    {"two_processes_slower_one", 2.0 * a / median(slower)},
                    {"two_threads_apart", 2.0 * a / median(apart)},
                    {"two_threads_one_barrier_per_step", 2.0 * a / median(meeting)},
                    {"two_threads_two_meetings_per_step", 2.0 * a / median(two_meetings)},
                    {"two_threads_two_meetings_and_halo", 2.0 * a / median(with_halo)}};
    j["round_trip_ns"] = {{"median", median(trip)},
                          {"min", *std::min_element(trip.begin(), trip.end())},
                          {"max", *std::max_element(trip.begin(), trip.end())}};
    j["rounds_us"] = {{"alone", alone}, {"processes", procs}, {"processes_slower", slower},
                      {"apart", apart}, {"meeting", meeting}, {"two_meetings", two_meetings},
                      {"halo", with_halo}, {"round_trip_ns", trip}};
    std::cout << j.dump(2) << "\n";
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
