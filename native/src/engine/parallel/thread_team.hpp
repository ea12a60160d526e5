// The threads of the step's parallel regions and where they meet
// (engine/simulation.hpp, advance): thread t owns block t of the particles
// (NeighborList::block) and meets the others twice a step without an OpenMP
// barrier.
//
//  - After its first stage it publishes its drift statistics (publish) and
//    goes straight on with the rows of its block that read only its own
//    particles; the step's verdict (keep the neighbour list or rebuild it)
//    is known once every thread has published (Gate, poll), and every
//    thread reaches the same one from the same numbers.
//  - After its pairs and tail tasks it publishes that it has finished them
//    and waits for the others (meet), then adds the others' shares for its
//    block (engine/parallel/ghost_forces.hpp).
//
// Each thread writes only its own line and reads the others' (an OpenMP
// barrier counts arrivals on one shared line, which every arrival takes from
// the core that had it: box 3 Hz, 2 threads, docs/speed_accuracy.md). The
// numbers only grow, so the same records serve every step.
#pragma once
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/column.hpp"
#include "core/doorbell.hpp"
#include "engine/parallel/ghost_forces.hpp"
#include "engine/parallel/tail_tasks.hpp"
#include "engine/steal_choice.hpp"
#include "engine/timers.hpp"
#include "neighbor/neighbor_list.hpp"

namespace granular {

// Stats: the integrator's drift statistics (integrate/drift_stats.hpp).
template <int Dim, class Stats>
class ThreadTeam {
 public:
  using V = Vec<Dim>;
  using A = Ang<Dim>;

  // A thread's view of the step's verdict: whether every thread's first stage
  // stayed stable and within the skin. It is known once every thread has
  // published (Done); until then the thread may evaluate only the rows of its
  // block that read its own particles (NeighborList::own_end). Every thread
  // combines the same published numbers in the same order, so all reach the
  // same verdict without a barrier.
  struct Gate {
    long seq;
    bool known = false, go_on = false;
    Stats all{};
  };

  // The numbers of a stretch of steps between neighbour-list rebuilds, one
  // parallel region: step k (0, 1, ...) publishes its first stage as seq(k)
  // (Done) and claims its tail tasks with gen(k) (Claim). A stretch cut
  // short by a rebuild leaves its later numbers unused: they only have to
  // grow.
  struct Stretch {
    long seq0, gen0;
    StealChoice::Clock::time_point start;
    long seq(long k) const { return seq0 + k + 1; }
    long gen(long k) const { return gen0 + k + 1; }
  };

  // Before a parallel region of nt threads opens (inside it, sizing would
  // cost a barrier every step): the records, the ghost buffers for n
  // particles, the claims, and room for max_fast fast particles a thread.
  void prepare(int nt, std::size_t n, std::size_t max_fast) {
    nt_ = nt;
    ghosts_.prepare(nt, n);
    tails_.prepare(nt);
    if (static_cast<int>(done_.size()) != nt) std::vector<Done>(static_cast<std::size_t>(nt)).swap(done_);
    for (Done& d : done_) d.fast.resize(max_fast);
  }
  // After a neighbour-list build: the tail tasks' buffers.
  void after_build(const NeighborList<Dim>& nl) { ghosts_.size_tasks(nl); }

  // A stretch of up to n steps; on two or more threads it is timed, for the
  // choice to take other blocks' tail tasks (engine/steal_choice.hpp).
  Stretch open_stretch(long n) {
    const Stretch s{seq_, gen_, nt_ > 1 ? StealChoice::Clock::now() : StealChoice::Clock::time_point{}};
    seq_ += n;
    gen_ += n;
    return s;
  }
  // After the stretch, which took `steps` steps.
  void close_stretch(const Stretch& s, long steps, PhaseTimers& timers) {
    if (nt_ == 1) return;
    StealChoice& c = tails_.steal_choice();
    const bool stole = c.steal();
    if (c.record(steps, StealChoice::Clock::now() - s.start)) {
      ++timers.steal_windows;
      timers.steal_windows_stealing += stole;
    }
  }
  // A force evaluation outside a stretch's steps: its claim number.
  long evaluation() { return ++gen_; }

  // The buffer that thread t's drift statistics name its fast particles into.
  std::vector<std::uint32_t>& fast_buffer(int t) { return done_[static_cast<std::size_t>(t)].fast; }

  // Thread t's first stage of step seq is done: its drift statistics, then
  // the step's number (a release store, so that whoever reads the number
  // also sees the statistics and the positions the thread moved). Returns
  // the thread's gate for the step.
  Gate publish(int t, long seq, const Stats& st) {
    Done& d = done_[static_cast<std::size_t>(t)];
    d.stats = st;
    d.seq.store(seq, std::memory_order_release);
    d.bell.ring();
    return Gate{seq};
  }

  // f(i) for every fast particle the threads published, in thread order,
  // until f returns false; returns whether it never did.
  template <class F>
  bool for_each_fast(F&& f) const {
    for (const Done& d : done_)
      for (std::uint32_t k = 0; k < d.stats.n_fast; ++k)
        if (!f(d.stats.fast[k])) return false;
    return true;
  }

  // Thread t's sinks for its block [lo, hi) of the store's forces f and
  // torques tq (engine/parallel/ghost_forces.hpp).
  Sinks<Dim> sinks(int t, std::size_t lo, std::size_t hi, V* f, A* tq) { return ghosts_.sinks(t, lo, hi, f, tq); }

  // Thread t's walk over the core rows of its block (NeighborList::core_end)
  // in one force evaluation: before each piece of rows the caller asks how
  // far it may go (until), and each piece then comes after a look at the gate
  // (none: the caller knows the positions are final everywhere). Rows from
  // own_end on read other blocks, so they wait for the verdict; go_on(all)
  // gives it from the combined statistics. Once the verdict is to rebuild,
  // stop() holds and no more rows may be evaluated.
  template <class GoOn>
  class CoreWalk {
   public:
    CoreWalk(ThreadTeam& team, int t, const NeighborList<Dim>& nl, Gate* gate, const GoOn& go_on)
        : team_(team), nl_(nl), gate_(gate), go_on_(go_on), t_(t), own_end_(nl.own_end(t)), zeroed_(team.nt_ == 1) {}

    // The end of the rows from r on, before e, that the thread may evaluate
    // now (e once the verdict is known).
    GRANULAR_INLINE std::size_t until(std::size_t r, std::size_t e) {
      std::size_t r1 = e;
      if (gate_ && !gate_->known) {
        r1 = std::min(e, r + kPollRows);
        if (r >= own_end_)
          team_.poll(*gate_, true, go_on_);
        else if (!team_.poll(*gate_, false, go_on_))
          r1 = std::min(r1, own_end_);
        if (gate_->known && !gate_->go_on) {
          stop_ = true;
          return r;
        }
      }
      // The thread zeroes the chunks of its ghost buffer that its rows write
      // just before the first row that may write one (rows from own_end on):
      // with a gate the verdict is known then, so every thread has finished
      // the step before, its ghost sums included; without one the region has
      // just opened. The lines it zeroes are those it is about to write, so
      // they come to its core once (a reader that zeroed what it added made
      // them cross three times a step).
      if (!zeroed_ && r1 > own_end_) {
        team_.ghosts_.zero(t_, nl_);
        zeroed_ = true;
      }
      return r1;
    }
    bool stop() const { return stop_; }

   private:
    ThreadTeam& team_;
    const NeighborList<Dim>& nl_;
    Gate* gate_;
    const GoOn& go_on_;
    int t_;
    std::size_t own_end_;
    bool zeroed_, stop_ = false;
  };
  // Thread t starts a force evaluation with its walk over its core rows.
  template <class GoOn>
  CoreWalk<GoOn> core_walk(int t, const NeighborList<Dim>& nl, Gate* gate, const GoOn& go_on) {
    if (t == stall_thread_) stall();
    return CoreWalk<GoOn>(*this, t, nl, gate, go_on);
  }

  // After the core rows (each read only the block's own particles if the
  // verdict is not known yet): waits for the verdict and returns it (true
  // without a gate).
  template <class GoOn>
  bool verdict(Gate* gate, const GoOn& go_on) const {
    if (gate && !gate->known) poll(*gate, true, go_on);
    return !gate || gate->go_on;
  }

  // Thread t runs tail tasks of evaluation gen (engine/parallel/tail_tasks.hpp):
  // run(u, k) evaluates task k of block u into task_sinks(u, k).
  template <class Run>
  void run_tails(int t, long gen, Run&& run) {
    if (nt_ > 1) tails_.run(t, nt_, gen, run);
  }
  // Tail task k of block u's sinks, its buffer zeroed (by the thread that runs it).
  TaskSinks<Dim> task_sinks(int u, int k, const NeighborList<Dim>& nl) {
    return ghosts_.task_sinks(static_cast<std::size_t>(u * NeighborList<Dim>::kTails + k), nl);
  }

  // Thread t has finished its pairs and tail tasks: it meets the others (at
  // the gate's step, or at a barrier without one) and adds their shares for
  // its block [lo, hi) into the store's forces f and torques tq.
  void meet_and_sum(int t, std::size_t lo, std::size_t hi, const NeighborList<Dim>& nl, const Gate* gate, V* f, A* tq) {
    if (nt_ == 1) return;
    if (gate)
      meet(t, gate->seq);
    else {
#pragma omp barrier
    }
    ghosts_.add_into(t, lo, hi, nl, f, tq);
  }

  // The tail tasks of other blocks the threads ran since the last call
  // (between regions).
  long collect_taken() { return tails_.collect_taken(); }

  // Whether a free thread takes other blocks' tail tasks (timed, or fixed by
  // a test).
  StealChoice& steal_choice() { return tails_.steal_choice(); }

  // For tests: thread `thread` spins for `d` at the start of each force
  // evaluation, so that the others take its tail tasks (-1: none).
  void stall_for_tests(int thread, std::chrono::microseconds d) {
    stall_thread_ = thread;
    stall_for_ = d;
  }

 private:
  // Rows evaluated between two looks at the other threads' flags.
  static constexpr std::size_t kPollRows = 16;

  // What a thread publishes after its first stage (publish) and after its
  // pairs (meet). One cache line each, so that one thread's writes do not
  // evict another's.
  struct alignas(kCacheLine) Done {
    std::atomic<long> seq{0};
    std::atomic<long> met{0};  // the last step whose pairs the thread finished (meet)
    mutable Doorbell bell;     // rung after seq or met is published; the waiters sleep on it
    Stats stats;
    std::vector<std::uint32_t> fast;  // the buffer that stats.fast names the fast particles into
    Done() = default;
    // Copied with the simulation (between steps, when no thread writes it).
    Done(const Done& o)
        : seq(o.seq.load(std::memory_order_relaxed)),
          met(o.met.load(std::memory_order_relaxed)),
          bell(o.bell),
          stats(o.stats),
          fast(o.fast) {}
    Done& operator=(const Done& o) {
      seq.store(o.seq.load(std::memory_order_relaxed), std::memory_order_relaxed);
      met.store(o.met.load(std::memory_order_relaxed), std::memory_order_relaxed);
      stats = o.stats;
      fast = o.fast;
      return *this;
    }
  };

  // Looks whether every thread has published; with wait, waits until they
  // have (spinning, then sleeping: core/doorbell.hpp). Returns whether the
  // verdict is known.
  template <class GoOn>
  bool poll(Gate& g, bool wait, const GoOn& go_on) const {
    for (const Done& d : done_) {
      const auto published = [&] { return d.seq.load(std::memory_order_acquire) == g.seq; };
      if (!published()) {
        if (!wait) return false;
        d.bell.wait_until(published);
      }
    }
    Stats all;
    for (const Done& d : done_) all.combine(d.stats);
    g.all = all;
    g.go_on = go_on(all);
    g.known = true;
    return true;
  }

  // Thread t publishes that it has finished step seq's pairs and waits until
  // every thread has.
  void meet(int t, long seq) {
    Done& mine = done_[static_cast<std::size_t>(t)];
    mine.met.store(seq, std::memory_order_release);
    mine.bell.ring();
    for (const Done& d : done_) d.bell.wait_until([&] { return d.met.load(std::memory_order_acquire) >= seq; });
  }

  void stall() const {
    const auto until = std::chrono::steady_clock::now() + stall_for_;
    while (std::chrono::steady_clock::now() < until) Doorbell::pause();
  }

  int nt_ = 1;
  std::vector<Done> done_;  // per thread
  long seq_ = 0;            // the last step number handed out (Done)
  long gen_ = 0;            // the last claim number handed out (Claim)
  GhostForces<Dim> ghosts_;
  TailTasks<NeighborList<Dim>::kTails> tails_;
  int stall_thread_ = -1;
  std::chrono::microseconds stall_for_{0};
};

}  // namespace granular
