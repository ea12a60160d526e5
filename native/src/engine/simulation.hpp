// The time step, readable top to bottom. The contact law, integrator and walls
// are template parameters: the scene layer picks them once and the per-contact
// loop contains no dispatch.
#pragma once
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "boundary/periodic_axes.hpp"
#include "contact/pair_batch.hpp"
#include "core/domain.hpp"
#include "core/doorbell.hpp"
#include "core/particles.hpp"
#include "core/threads.hpp"
#include "engine/steal_choice.hpp"
#include "engine/timers.hpp"
#include "neighbor/neighbor_list.hpp"

namespace granular {

// Raised when the dynamics blows up; the message says where and why.
class UnstableError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

template <int Dim, class Law, class Integrator, class... Walls>
class Simulation {
 public:
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  static constexpr int kDim = Dim;

  // Whether W is among the walls.
  template <class W>
  static constexpr bool kHasWall = (false || ... || std::is_same_v<W, Walls>);
  // A periodic domain only with the PeriodicAxes boundary (core/domain.hpp).
  static constexpr bool kPeriodic = kHasWall<PeriodicAxes>;
  ParticleStore<Dim> p;
  Domain<Dim, kPeriodic> domain;
  Law law;
  Integrator integrator;
  std::tuple<Walls...> walls;
  double skin = 0.4;
  int exclude_species = -1;  // pairs with both particles of this species are not listed (wall particles)
  double time = 0.0;
  long step_count = 0;
  PhaseTimers timers;
  std::string stability_hint;  // the likely cause, for the unstable-run message (engine/health.hpp)
  // No source in the scene drives a particle faster (engine/health.hpp): a
  // faster one means energy growing without a source. Checked every step, at
  // no cost, with the neighbour-list move limit.
  double max_speed = std::numeric_limits<double>::infinity();
  std::string speed_sources;

  // Call once the store, domain, law and walls are set: builds the list and the
  // forces at t = 0 that the first half kick needs.
  void init() {
    set_d_min();
    rebuild();
    compute_forces();
    integrator.start(p);
  }

  // One step (advance(1)).
  void step() { advance(1); }

  // n steps. Between neighbour-list rebuilds the steps run in one parallel
  // region: every thread moves its own block, evaluates its block's pairs and
  // finishes it, meeting the others at one barrier a step (the ghost forces),
  // and goes straight on to its next step. Between the first stage and the
  // pairs there is no barrier: each thread publishes its drift statistics and
  // goes on with the rows that read only its own particles while the others
  // finish (Gate below). Nor between one step's second stage and the next
  // step's first stage, which run as one pass over the block
  // (second_then_first: each particle's columns read and written once, the
  // same bits as the two stages apart): after the barrier each thread reads
  // and writes its own block only, until the next step's gate, which every
  // thread passes only once all have finished the step before. A step whose
  // verdict is to rebuild ends the region; the list is rebuilt, the step's
  // forces computed and the region opened again. The caller picks n so that nothing reads the
  // state in between (engine/run_control.hpp, next_stop).
  void advance(long n) {
    const int nt = omp_get_max_threads();
    while (n > 0) {
      // Each stretch between rebuilds is timed, on two or more threads, for
      // the choice to take other blocks' tail tasks (engine/steal_choice.hpp).
      const auto stretch_start = nt > 1 ? StealChoice::Clock::now() : StealChoice::Clock::time_point{};
      const long n_start = n;
      const auto timed = [&] {
        if (nt == 1) return;
        const bool stole = steal_choice_.steal();
        if (steal_choice_.record(n_start - n, StealChoice::Clock::now() - stretch_start)) {
          ++timers.steal_windows;
          timers.steal_windows_stealing += stole;
        }
      };
      if (nt != nl_.threads()) rebuild();  // the thread count changed since the last build
      prepare_buffers(nt);
      const auto& xref = nl_.reference_positions();
      const long seq0 = seq_;
      // Claim numbers for the region's evaluations (Claim): one a step.
      const long gen0 = gen_;
      gen_ += n;
      const double dt = integrator.dt;
      const double time0 = time;
      // Written by the master: the steps completed, the time after them, and
      // for a step that ends the region to rebuild (completed < n), its
      // statistics.
      long completed = 0;
      double time_out = time0;
      typename Integrator::DriftStats st;
#pragma omp parallel num_threads(nt)
      {
        const int t = omp_get_thread_num();
        const auto [lo, hi] = nl_.block(t);
        Done& dn = done_[t];
        // Every thread sums the time as the master does: the same bits.
        double tm = time0;
        const auto fast = [&] {
          return Integrator::DriftStats::naming_fast(0.5 * skin, dn.fast.data(),
                                                     static_cast<std::uint32_t>(dn.fast.size()));
        };
        long k = 0;
        Stamps ts;
        dn.stats = stage_with_walls(lo, hi, tm + dt, fast(), ts, [&](std::size_t a, std::size_t e, const auto& seed) {
          return integrator.first_half(p, domain, xref, a, e, tm + dt, seed);
        });
        for (; k < n; ++k) {
          const long seq = seq0 + k + 1;
          dn.seq.store(seq, std::memory_order_release);
          dn.bell.ring();
#pragma omp master
          ts.first = PhaseTimers::Clock::now();
          Gate g{seq};
          // Every thread reaches the same verdict from the same numbers, so
          // all leave the loop at the same step.
          if (!forces_in_region(t, nt, lo, hi, tm + dt, gen0 + k + 1, ts, &g)) {
#pragma omp master
            {
              st = g.all;
              timers.add(Phase::integrate, ts.first - ts.start);
            }
            break;
          }
          tm += dt;
          if (k + 1 == n) {
            finish(lo, hi, ts);
#pragma omp master
            add_timers(ts);
            ++k;
            break;
          }
          // This step's second stage and the next step's first in one pass
          // over the block (the same bits as the two stages apart).
          dn.stats = stage_with_walls(lo, hi, tm + dt, fast(), ts, [&](std::size_t a, std::size_t e, const auto& seed) {
            return integrator.second_then_first(p, domain, xref, a, e, tm + dt, seed);
          });
#pragma omp master
          {
            ts.end = PhaseTimers::Clock::now();
            add_timers(ts);
            ts.start = ts.end;
            ts.walls_in_stage = PhaseTimers::Clock::duration::zero();
          }
        }
#pragma omp master
        {
          completed = k;
          time_out = tm;
        }
      }
      collect_tails();
      seq_ += completed;
      time = time_out;
      step_count += completed;
      n -= completed;
      if (n == 0) {
        timed();
        break;
      }
      // The step whose verdict was to rebuild: its first stage is done.
      ++seq_;
      check_stable(st);  // throws if unstable
      {
        ScopedPhase ph(timers, Phase::neighbor);
        rebuild(false);
      }
      Stamps ts;
      ts.first = ts.start;
      const long gen = ++gen_;
#pragma omp parallel num_threads(nt)
      {
        const int t = omp_get_thread_num();
        const auto [lo, hi] = nl_.block(t);
        forces_in_region(t, nt, lo, hi, time + dt, gen, ts);
        finish(lo, hi, ts);
      }
      add_timers(ts);
      collect_tails();
      time += dt;
      ++step_count;
      --n;
      timed();
    }
  }

  // Restart from a checkpoint: the store already holds the saved state (in the
  // saved order); x_ref are the positions the saved neighbour list was built
  // from. Building from them lists the same pairs in the same rows, and
  // reorders nothing (the cell sort is stable and the store is in its order),
  // so the next step sums forces exactly as the interrupted run would have.
  void restore_neighbors(Column<V> x_ref) {
    set_d_min();
    const Column<std::int64_t> saved_order = p.id;
    std::swap(p.x, x_ref);
    rebuild();
    std::swap(p.x, x_ref);
    if (p.id != saved_order)
      throw std::runtime_error("checkpoint: the saved neighbour-list reference does not match the saved particle order");
  }

  // forces = false: f and tq are recomputed before anything reads them (the
  // rebuild inside a step, after the drift), so the reorder skips them.
  void rebuild(bool forces = true) {
    nl_.build(p, domain, skin, Law::kRangeFactor, exclude_species, forces, kParticleWeight);
    // The tail tasks' buffers, one entry per particle of the chunks each
    // writes (zeroed by the thread that runs the task).
    const std::size_t ntasks = static_cast<std::size_t>(nl_.tails() * nl_.threads());
    task_f_.resize(ntasks);
    task_t_.resize(ntasks);
    for (std::size_t task = 0; task < ntasks; ++task) {
      const std::size_t m = nl_.tail_chunks(task).size() * NeighborList<Dim>::kChunk;
      task_f_[task].resize(m);
      task_t_[task].resize(m);
    }
  }

  // A particle's work in a step besides its pairs, in listed pairs (the
  // threads' blocks balance it, neighbor/neighbor_list.hpp): its ghost sums,
  // its integration and the walls' checks, as each declares.
  static constexpr std::uint32_t kParticleWeight = 1 + Integrator::kWeight + (0 + ... + Walls::kWeight);

  // Forces at the current state (no integration); used at start-up.
  void compute_forces() {
    const int nt = omp_get_max_threads();
    if (nt != nl_.threads()) rebuild();
    prepare_buffers(nt);
    Stamps ts;
    const long gen = ++gen_;
#pragma omp parallel num_threads(nt)
    {
      const int t = omp_get_thread_num();
      const auto [lo, hi] = nl_.block(t);
      forces_in_region(t, nt, lo, hi, time, gen, ts);
    }
    collect_tails();
  }

  const NeighborList<Dim>& neighbors() const { return nl_; }

  // The pair loop against a bare kernel: the contact law alone, on one thread,
  // over a fixed list of the pairs in contact now (no list walk, no range test,
  // no buffers). Returns the number of contacts and the nanoseconds per contact
  // (best of `passes` passes), for `granular bench` (engine/timers.hpp).
  std::pair<std::size_t, double> bare_kernel(int passes = 20) const {
    std::vector<std::uint32_t> ci, cj;
    for (int t = 0; t < nl_.threads(); ++t) {
      const auto [lo, hi] = nl_.row_block(t);
      for (std::size_t i = lo; i < hi; ++i)
        for (std::uint32_t k = nl_.begin(i); k < nl_.end(i); ++k) {
          const std::uint32_t j = nl_.col(t)[k];
          const double rc = Law::range(p.d[i], p.d[j]);
          if (domain.min_image(p.x[i] - p.x[j]).squaredNorm() < rc * rc) {
            ci.push_back(static_cast<std::uint32_t>(i));
            cj.push_back(j);
          }
        }
    }
    if (ci.empty()) return {0, 0.0};
    std::vector<V> F(p.size(), V::Zero());
    std::vector<A> T(p.size(), A::Zero());
    double best = std::numeric_limits<double>::infinity();
    for (int pass = 0; pass < passes; ++pass) {
      const auto t0 = PhaseTimers::Clock::now();
      for (std::size_t c = 0; c < ci.size(); ++c) {
        const std::uint32_t i = ci[c], j = cj[c];
        const V dr = domain.min_image(p.x[i] - p.x[j]);
        const auto r = law.pair_force(dr, dr.squaredNorm(), p.d[i], p.d[j], p.v[i] - p.v[j], p.w[i], p.w[j],
                                      p.species[i], p.species[j], p.inv_m[i], p.inv_m[j]);
        F[i] += r.f;
        F[j] -= r.f;
        T[i] += r.ti;
        T[j] += r.tj;
      }
      best = std::min(best, std::chrono::duration<double>(PhaseTimers::Clock::now() - t0).count());
    }
    volatile double sink = F[0][0] + T[0][0];  // keep the loop
    (void)sink;
    return {ci.size(), 1e9 * best / static_cast<double>(ci.size())};
  }

  // Unstable if any particle moved further in one step than half the smallest
  // diameter (a collision passes in one or two steps, unresolved: Eq. (1)
  // diverges or grains pass through each other), faster than anything drives
  // it, or if anything is not finite. The neighbour list sets no limit here:
  // advance() rebuilds it from the current positions whenever the two largest
  // displacements since the last build exceed the skin, before any force is
  // evaluated, so it holds every pair in range however far a particle moved.
  double max_step_move() const { return std::min(0.5 * d_min_, max_speed * integrator.dt); }

 private:
  // The smallest diameter, for the step-move limit.
  void set_d_min() {
    d_min_ = std::numeric_limits<double>::infinity();
    for (double d : p.d) d_min_ = std::min(d_min_, d);
  }

  // The per-thread ghost buffers and contact batches, sized before a parallel
  // region opens (inside it, sizing them would cost a barrier every step).
  void prepare_buffers(int nt) {
    const std::size_t n = p.size();
    const std::size_t nb = nt > 1 ? static_cast<std::size_t>(nt) : 0;
    if (fbuf_.size() != nb || (nb > 0 && fbuf_[0].size() != n)) {
      fbuf_.assign(nb, Column<V>(n, V::Zero()));  // each thread zeroes what it writes: forces_in_region
      tbuf_.assign(nb, Column<A>(n, A::Zero()));
    }
    const std::size_t ntasks = nb * NeighborList<Dim>::kTails;
    if (claims_.size() != ntasks) std::vector<Claim>(ntasks).swap(claims_);
    if constexpr (HasPairBatch<Law, Dim>::value)
      if (static_cast<int>(batch_.size()) != nt) batch_.resize(nt);
    if (static_cast<int>(done_.size()) != nt) std::vector<Done>(static_cast<std::size_t>(nt)).swap(done_);
    for (Done& d : done_) d.fast.resize(max_fast());
  }

  // What a thread publishes after its first stage: its drift statistics, then
  // the step's number (a release store, so that whoever reads the number also
  // sees the statistics and the positions the thread moved). One cache line
  // each, so that one thread's writes do not evict another's.
  struct alignas(kCacheLine) Done {
    std::atomic<long> seq{0};
    std::atomic<long> met{0};  // the last step whose pairs the thread finished (meet)
    mutable Doorbell bell;     // rung after seq or met is published; the waiters sleep on it
    long tails_taken = 0;      // tail tasks of other blocks this thread ran (run_tails)
    typename Integrator::DriftStats stats;
    std::vector<std::uint32_t> fast;  // the buffer that stats.fast names the fast particles into
    Done() = default;
    // Copied with the simulation (between steps, when no thread writes it).
    Done(const Done& o)
        : seq(o.seq.load(std::memory_order_relaxed)),
          met(o.met.load(std::memory_order_relaxed)),
          bell(o.bell),
          tails_taken(o.tails_taken),
          stats(o.stats),
          fast(o.fast) {}
    Done& operator=(const Done& o) {
      seq.store(o.seq.load(std::memory_order_relaxed), std::memory_order_relaxed);
      met.store(o.met.load(std::memory_order_relaxed), std::memory_order_relaxed);
      tails_taken = o.tails_taken;
      stats = o.stats;
      fast = o.fast;
      return *this;
    }
  };

  // A thread's view of the step's verdict: whether every thread's first stage
  // stayed stable and within the skin. It is known once every thread has
  // published (Done); until then the thread may evaluate only the rows of its
  // block that read its own particles (NeighborList::own_end). Every thread
  // combines the same published numbers in the same order, so all reach the
  // same verdict without a barrier.
  struct Gate {
    long seq;
    bool known = false, go_on = false;
    typename Integrator::DriftStats all{};
  };
  // Particles per piece of a first stage and the walls (stage_with_walls):
  // their forces and torques, 24 kB in 3D, stay in the core's first-level cache.
  static constexpr std::size_t kWallPiece = 512;
  // Rows evaluated between two looks at the other threads' flags.
  static constexpr std::size_t kPollRows = 16;

  // Past the two-largest test the list stays in use while no more than
  // n / kFastShare particles have moved more than skin/2 (at most skin) and
  // every pair of those in range is listed (NeighborList::fast_pairs_listed).
  // The largest of 10^5 particles reaches skin/2 sooner than the largest of
  // 10^3, so the two-largest test alone rebuilt the long drum 1.4 times as
  // often per step; a share puts both sizes at the same quantile.
  // Drum #A at 103 840 particles, 0.5 rotations: 281 builds, 183 at a share
  // of 256, 171 at 64; 968 particles: 962, 817, 644 (docs/speed_accuracy.md).
  static constexpr std::size_t kFastShare = 64;
  std::size_t max_fast() const { return p.size() / kFastShare; }
  // Every thread runs it on the same published numbers: the same verdict.
  bool fast_pairs_listed(const typename Integrator::DriftStats& all) const {
    if (all.n_fast > max_fast() || !(all.max_disp2 <= skin * skin)) return false;
    return nl_.fast_pairs_listed(p, domain, std::sqrt(all.max_disp2), [&](auto&& f) {
      for (const Done& d : done_)
        for (std::uint32_t k = 0; k < d.stats.n_fast; ++k)
          if (!f(d.stats.fast[k])) return false;
      return true;
    });
  }

  // Looks whether every thread has published; with wait, waits until they
  // have (spinning, then sleeping: core/doorbell.hpp). Returns whether the verdict is known.
  bool poll(Gate& g, bool wait) const {
    for (const Done& d : done_) {
      const auto published = [&] { return d.seq.load(std::memory_order_acquire) == g.seq; };
      if (!published()) {
        if (!wait) return false;
        d.bell.wait_until(published);
      }
    }
    typename Integrator::DriftStats all;
    for (const Done& d : done_) combine_into(all, d.stats);
    g.all = all;
    g.go_on = stable(all) && (all.disp_bound() <= skin || fast_pairs_listed(all));
    g.known = true;
    return true;
  }
  // The step's barrier inside advance()'s region: thread t publishes that
  // it has finished step seq's pairs and waits until every thread has. Each
  // thread writes only its own line and reads the others' (an OpenMP
  // barrier counts arrivals on one shared line, which every arrival takes
  // from the core that had it: box 3 Hz, 2 threads, docs/speed_accuracy.md).
  // The numbers only grow, so the same flags serve every step.
  void meet(int t, long seq) {
    Done& mine = done_[static_cast<std::size_t>(t)];
    mine.met.store(seq, std::memory_order_release);
    mine.bell.ring();
    for (const Done& d : done_) d.bell.wait_until([&] { return d.met.load(std::memory_order_acquire) >= seq; });
  }

  // Where a thread's pair loop puts forces and torques: the store for the
  // particles of its block [lo, lo + len), its ghost buffer for the others
  // (the store itself when one thread owns every particle).
  struct Sinks {
    V* f;
    A* t;
    V* gf;
    A* gt;
    std::size_t lo, len;
    V& force(std::uint32_t j) const { return (j - lo < len ? f : gf)[j]; }
    A& torque(std::uint32_t j) const { return (j - lo < len ? t : gt)[j]; }
    V& own_force(std::size_t i) const { return f[i]; }
    A& own_torque(std::size_t i) const { return t[i]; }
  };
  // Where a tail task puts them: its buffer, for every particle
  // (NeighborList::tail_offsets).
  struct TaskSinks {
    V* f;
    A* t;
    const std::int64_t* off;
    std::int64_t at(std::size_t j) const {
      return off[j / NeighborList<Dim>::kChunk] + static_cast<std::int64_t>(j);
    }
    V& force(std::uint32_t j) const { return f[at(j)]; }
    A& torque(std::uint32_t j) const { return t[at(j)]; }
    V& own_force(std::size_t i) const { return f[at(i)]; }
    A& own_torque(std::size_t i) const { return t[at(i)]; }
  };

  struct Stamps {
    PhaseTimers::Clock::time_point start = PhaseTimers::Clock::now(), first = start, walls_done = start,
                                   pairs_done = start, end = start;
    PhaseTimers::Clock::duration walls_in_stage{};  // the walls' pieces within the first stage (stage_with_walls)
  };

  // A step's phases, from the master's stamps.
  void add_timers(const Stamps& ts) {
    timers.add(Phase::integrate, ts.first - ts.start + (ts.end - ts.pairs_done) - ts.walls_in_stage);
    timers.add(Phase::walls, ts.walls_done - ts.first + ts.walls_in_stage);
    timers.add(Phase::pairs, ts.pairs_done - ts.walls_done);
  }

  // The second stage on the thread's own block.
  void finish(std::size_t lo, std::size_t hi, Stamps& ts) {
    integrator.second_half(p, domain, lo, hi);
#pragma omp master
    ts.end = PhaseTimers::Clock::now();
  }

  // Called by every thread of a parallel region. Thread t owns the particles
  // of its block [lo, hi) (its rows of the neighbour list). First the wall
  // contacts, per particle of the block (they need no other block). The rows of the
  // block's core (NeighborList::core_end) write their particles' force and
  // torque straight into the store, and a contact's share for a particle
  // outside the block into the thread's ghost buffer (indexed like the
  // store). The block's tail tasks (NeighborList::kTails) follow, each run by
  // whichever thread claims it first (run_tails) and writing every share into
  // the task's own buffer. After one barrier each thread adds, for its block,
  // the other threads' ghost entries in thread order and then every task's
  // entries in task order: the sums are bitwise repeatable for a thread
  // count, whoever ran the tasks; one thread has no ghosts and no tasks. Only
  // the chunks of a buffer its writer touches (NeighborList::touched,
  // tail_chunks) are read and zeroed, so little data crosses between cores.
  // t_pos: the time of the
  // positions (moving walls are placed at it). gen: a number larger than any
  // earlier evaluation's, for the claims. With a gate (in advance(), straight
  // after the first stage), the rows that read another block, and the tail
  // tasks, wait for the verdict, and a verdict to rebuild stops the loop:
  // then every thread returns false, before the barrier, and the forces are
  // recomputed after the rebuild. Without one the caller knows the positions
  // are final everywhere.
  bool forces_in_region(int t, int nt, std::size_t lo, std::size_t hi, double t_pos, long gen, Stamps& ts,
                        Gate* gate = nullptr) {
    constexpr std::size_t kChunk = NeighborList<Dim>::kChunk;
    // The block's forces and torques start from the walls' (start_with_walls).
    // With a gate the first stage has just done it, piece by piece.
    if (!gate)
      for (std::size_t a = lo; a < hi; a += kWallPiece) start_with_walls(a, std::min(hi, a + kWallPiece), t_pos);
#pragma omp master
    ts.walls_done = PhaseTimers::Clock::now();
    Sinks sk{p.f.data(), p.tq.data(), p.f.data(), p.tq.data(), lo, hi - lo};
    if constexpr (HasPairBatch<Law, Dim>::value) batch_[t].n = 0;
    if (nt > 1) {
      sk.gf = fbuf_[static_cast<std::size_t>(t)].data();
      sk.gt = tbuf_[static_cast<std::size_t>(t)].data();
    }
    if (t == stall_thread) stall();
    // The core's rows in pieces, each after a look at the gate.
    const std::size_t own_end = nl_.own_end(t);
    bool stop = false;
    // The thread zeroes the chunks of its ghost buffer that its rows write
    // just before the first row that may write one (rows from own_end on):
    // with a gate the verdict is known then, so every thread has finished the
    // step before, its ghost sums included; without one the region has just
    // opened. The lines it zeroes are those it is about to write, so they
    // come to its core once (a reader that zeroed what it added made them
    // cross three times a step).
    bool zeroed = nt == 1;
    nl_.for_row_segments(lo, nl_.core_end(t), [&](std::size_t a, std::size_t e, const std::uint32_t* col) {
      for (std::size_t r = a; r < e && !stop;) {
        // Once the verdict is known, the rest of the piece in one go.
        std::size_t r1 = e;
        if (gate && !gate->known) {
          r1 = std::min(e, r + kPollRows);
          if (r >= own_end)
            poll(*gate, true);
          else if (!poll(*gate, false))
            r1 = std::min(r1, own_end);
          if (gate->known && !gate->go_on) {
            stop = true;
            return;
          }
        }
        if (!zeroed && r1 > own_end) {
          zero_ghosts(t);
          zeroed = true;
        }
        pairs(t, col, r, r1, sk);
        r = r1;
      }
    });
    if (stop) return false;
    flush_pairs(t, sk);
    if (gate && !gate->known) poll(*gate, true);  // every core row read only the block's own particles
    if (gate && !gate->go_on) return false;
    if (nt > 1) {
      run_tails(t, nt, gen);
      if (gate)
        meet(t, gate->seq);
      else {
#pragma omp barrier
      }
      // Add the other threads' ghost entries for this block, in thread
      // order, then the tasks' entries, in task order. Their writers zero
      // them before they next write them, after the next step's gate, which
      // no thread passes before all have finished this sum.
      const std::size_t ntasks = task_f_.size();
      for (std::size_t i = lo; i < hi;) {
        const std::size_t c = i / kChunk, e = std::min(hi, (c + 1) * kChunk);
        for (int u = 0; u < nt; ++u)
          if (u != t && nl_.touched(u, c)) {
            const V* gf = fbuf_[static_cast<std::size_t>(u)].data();
            const A* gt = tbuf_[static_cast<std::size_t>(u)].data();
            for (std::size_t q = i; q < e; ++q) {
              p.f[q] += gf[q];
              p.tq[q] += gt[q];
            }
          }
        for (std::size_t task = 0; task < ntasks; ++task)
          if (nl_.tail_touched(task, c)) {
            const std::int64_t o = nl_.tail_offsets(task)[c];
            const V* bf = task_f_[task].data();
            const A* bt = task_t_[task].data();
            for (std::size_t q = i; q < e; ++q) {
              p.f[q] += bf[o + static_cast<std::int64_t>(q)];
              p.tq[q] += bt[o + static_cast<std::int64_t>(q)];
            }
          }
        i = e;
      }
    }
#pragma omp master
    ts.pairs_done = PhaseTimers::Clock::now();
    return true;
  }

  // Particles [a, e): forces and torques zeroed, then the walls' contacts
  // added (walls read and write the particles' own columns only).
  void start_with_walls(std::size_t a, std::size_t e, double t_pos) {
    std::fill(p.f.begin() + static_cast<std::ptrdiff_t>(a), p.f.begin() + static_cast<std::ptrdiff_t>(e), V::Zero());
    std::fill(p.tq.begin() + static_cast<std::ptrdiff_t>(a), p.tq.begin() + static_cast<std::ptrdiff_t>(e), A::Zero());
    std::apply([&](const auto&... w) { (w.apply(p, law, a, e, t_pos), ...); }, walls);
  }

  // A first stage (stage(a, e, seed): the integrator's, on particles [a, e),
  // its drift statistics continued from seed) over the block [lo, hi), a
  // piece at a time, each piece's forces then started from the walls' at the
  // moved positions (time t_pos) while its columns are in the core's cache.
  // In a separate pass after the pairs, the walls cost a 10^5-particle drum
  // 10 % of a step against 5 % at 10^4: each pass over its columns came from
  // memory (docs/speed_accuracy.md). The statistics are those of one pass:
  // the pieces go in order, each continuing the last.
  template <class Stage>
  typename Integrator::DriftStats stage_with_walls(std::size_t lo, std::size_t hi, double t_pos,
                                                   typename Integrator::DriftStats st, Stamps& ts, Stage&& stage) {
    const bool master = omp_get_thread_num() == 0;
    for (std::size_t a = lo; a < hi; a += kWallPiece) {
      const std::size_t e = std::min(hi, a + kWallPiece);
      st = stage(a, e, st);
      const auto t0 = master ? PhaseTimers::Clock::now() : PhaseTimers::Clock::time_point{};
      start_with_walls(a, e, t_pos);
      if (master) ts.walls_in_stage += PhaseTimers::Clock::now() - t0;
    }
    return st;
  }

  // Rows [a, e) of col into the sinks, through thread t's batch where the law has a batch kernel.
  template <class S>
  void pairs(int t, const std::uint32_t* col, std::size_t a, std::size_t e, const S& sk) {
    if constexpr (HasPairBatch<Law, Dim>::value)
      pairs_batched(batch_[t], col, a, e, sk);
    else
      pairs_scalar(col, a, e, sk);
  }
  // Evaluates what is left in thread t's batch into the sinks.
  template <class S>
  void flush_pairs(int t, const S& sk) {
    if constexpr (HasPairBatch<Law, Dim>::value)
      if (batch_[t].n > 0) flush(batch_[t], sk);
  }

  // A tail task taken at most once per evaluation: gen is the last
  // evaluation that claimed it. One cache line each.
  struct alignas(kCacheLine) Claim {
    std::atomic<long> gen{0};
    Claim() = default;
    Claim(const Claim& o) : gen(o.gen.load(std::memory_order_relaxed)) {}
    Claim& operator=(const Claim& o) {
      gen.store(o.gen.load(std::memory_order_relaxed), std::memory_order_relaxed);
      return *this;
    }
  };
  bool claim(std::size_t task, long gen) {
    std::atomic<long>& g = claims_[task].gen;
    long old = g.load(std::memory_order_relaxed);
    return old < gen && g.compare_exchange_strong(old, gen, std::memory_order_acq_rel);
  }

  // Thread t runs its own block's tail tasks in order, as long as no other
  // thread has taken them, then takes the other blocks' from their ends
  // (the next block first) until it finds one taken. A task's rows read
  // other blocks' particles, so this runs once every thread's first stage is
  // done (the gate's verdict, or a region without a gate).
  void run_tails(int t, int nt, long gen) {
    constexpr int kT = NeighborList<Dim>::kTails;
    for (int k = 0; k < kT; ++k)
      if (claim(static_cast<std::size_t>(t * kT + k), gen)) run_tail(t, t, k);
    for (int s = 1; s < nt && steal_choice_.steal(); ++s) {
      const int u = (t + s) % nt;
      for (int k = kT - 1; k >= 0; --k) {
        if (!claim(static_cast<std::size_t>(u * kT + k), gen)) break;
        run_tail(t, u, k);
        ++done_[static_cast<std::size_t>(t)].tails_taken;
      }
    }
  }
  // Thread t runs tail task k of block u into the task's buffer.
  void run_tail(int t, int u, int k) {
    const std::size_t task = static_cast<std::size_t>(u * NeighborList<Dim>::kTails + k);
    Column<V>& bf = task_f_[task];
    Column<A>& bt = task_t_[task];
    std::fill(bf.begin(), bf.end(), V::Zero());
    std::fill(bt.begin(), bt.end(), A::Zero());
    const TaskSinks sk{bf.data(), bt.data(), nl_.tail_offsets(task)};
    const auto [a, e] = nl_.tail(u, k);
    nl_.for_row_segments(a, e, [&](std::size_t r, std::size_t re, const std::uint32_t* col) { pairs(t, col, r, re, sk); });
    flush_pairs(t, sk);
  }

  // Testing: stall_thread spins for stall_for at the start of each force
  // evaluation, so that the others take its tail tasks.
 public:
  int stall_thread = -1;
  std::chrono::microseconds stall_for{0};
  // Whether a free thread takes other blocks' tail tasks (timed, or fixed by
  // a test).
  StealChoice& steal_choice() { return steal_choice_; }

 private:
  // Moves the threads' counts of tail tasks taken into the timers (between regions).
  void collect_tails() {
    for (Done& d : done_) {
      timers.tails_taken += d.tails_taken;
      d.tails_taken = 0;
    }
  }
  void stall() const {
    const auto until = PhaseTimers::Clock::now() + stall_for;
    while (PhaseTimers::Clock::now() < until) Doorbell::pause();
  }

  // Zeroes the chunks of thread t's ghost buffer that its rows write.
  void zero_ghosts(int t) {
    constexpr std::size_t kChunk = NeighborList<Dim>::kChunk;
    V* gf = fbuf_[static_cast<std::size_t>(t)].data();
    A* gt = tbuf_[static_cast<std::size_t>(t)].data();
    const std::size_t n = p.size();
    for (const std::uint32_t c : nl_.touched_chunks(t)) {
      const std::size_t a = c * kChunk, e = std::min(n, a + kChunk);
      std::fill(gf + a, gf + e, V::Zero());
      std::fill(gt + a, gt + e, A::Zero());
    }
  }

  // The pair loop over rows [lo, hi) (held in col), one contact at a time:
  // i's own sums stay in registers.
  template <class S>
  void pairs_scalar(const std::uint32_t* col, std::size_t lo, std::size_t hi, const S& sk) {
    for (std::size_t i = lo; i < hi; ++i) {
      const V xi = p.x[i], vi = p.v[i];
      const A wi = p.w[i];
      const double di = p.d[i], inv_mi = p.inv_m[i];
      const int ci = p.species[i];
      V fi = V::Zero();
      A ti = A::Zero();
      for (std::uint32_t k = nl_.begin(i), ke = nl_.end(i); k < ke; ++k) {
        const std::uint32_t j = col[k];
        const V dr = domain.min_image(xi - p.x[j]);
        const double r2 = dr.squaredNorm();
        const double rc = Law::range(di, p.d[j]);
        if (r2 >= rc * rc) continue;
        const auto c =
            law.pair_force(dr, r2, di, p.d[j], vi - p.v[j], wi, p.w[j], ci, p.species[j], inv_mi, p.inv_m[j]);
        fi += c.f;
        ti += c.ti;
        sk.force(j) -= c.f;
        sk.torque(j) += c.tj;
      }
      sk.own_force(i) += fi;
      sk.own_torque(i) += ti;
    }
  }

  // Evaluates the contacts gathered in batch b and adds them to both
  // particles in the order they were found.
  template <class S>
  void flush(PairBatch<Dim>& b, const S& sk) {
    constexpr int kA = PairBatch<Dim>::kAng;
    law.pair_force_batch(b);
    for (int q = 0; q < b.n; ++q) {
      const std::uint32_t i = b.i[q], j = b.j[q];
      V& fi = sk.own_force(i);
      A& ti = sk.own_torque(i);
      V& fj = sk.force(j);
      A& tj = sk.torque(j);
      for (int a = 0; a < Dim; ++a) {
        fi[a] += b.f[a][q];
        fj[a] -= b.f[a][q];
      }
      for (int a = 0; a < kA; ++a) {
        ti[a] += b.ti[a][q];
        tj[a] += b.tj[a][q];
      }
    }
    b.n = 0;
  }

  // The pair loop over rows [lo, hi) (held in col) for a law with a batch
  // kernel (contact/pair_batch.hpp): the contacts in range are gathered into
  // batch b and evaluated together (flush); the caller flushes what is left.
  template <class S>
  void pairs_batched(PairBatch<Dim>& b, const std::uint32_t* col, std::size_t lo, std::size_t hi, const S& sk) {
    constexpr int kA = PairBatch<Dim>::kAng;
    constexpr std::uint32_t kSize = PairBatch<Dim>::kSize;
    for (std::size_t i = lo; i < hi; ++i) {
      const V xi = p.x[i], vi = p.v[i];
      const A wi = p.w[i];
      const double di = p.d[i], inv_mi = p.inv_m[i];
      const int ci = p.species[i];
      // The row in pieces that fit the batch.
      for (std::uint32_t k0 = nl_.begin(i), ke = nl_.end(i); k0 < ke;) {
        const std::uint32_t k1 = std::min(ke, k0 + kSize);
        if (b.n + (k1 - k0) > kSize) flush(b, sk);
        const int q0 = b.n;
        // The range test, without a branch: about half the listed pairs are
        // in contact, so a branch on it would mispredict half the time. Every
        // pair is written to the next free slot, which only a contact keeps.
        int q = q0;
        for (std::uint32_t k = k0; k < k1; ++k) {
          const std::uint32_t j = col[k];
          const V dr = domain.min_image(xi - p.x[j]);
          const double r2 = dr.squaredNorm();
          const double dj = p.d[j];
          const double rc = Law::range(di, dj);
          b.j[q] = j;
          for (int a = 0; a < Dim; ++a) b.dr[a][q] = dr[a];
          b.r2[q] = r2;
          b.dj[q] = dj;
          q += r2 < rc * rc;
        }
        b.n = q;
        // The rest of each contact's inputs.
        for (int c = q0; c < q; ++c) {
          const std::uint32_t j = b.j[c];
          const V vij = vi - p.v[j];
          const A& wj = p.w[j];
          b.i[c] = static_cast<std::uint32_t>(i);
          b.ci[c] = ci;
          b.cj[c] = p.species[j];
          for (int a = 0; a < Dim; ++a) b.v[a][c] = vij[a];
          for (int a = 0; a < kA; ++a) {
            b.wi[a][c] = wi[a];
            b.wj[a][c] = wj[a];
          }
          b.di[c] = di;
          b.inv_mi[c] = inv_mi;
          b.inv_mj[c] = p.inv_m[j];
        }
        k0 = k1;
      }
    }
  }

  // Adds one thread's drift statistics to st.
  static void combine_into(typename Integrator::DriftStats& st, const typename Integrator::DriftStats& s) {
    if (!(s.max_step2 <= st.max_step2)) st.max_step2 = s.max_step2;
    if (!(s.next_disp2 <= st.next_disp2)) st.push_disp(s.next_disp2);
    if (!(s.max_disp2 <= st.next_disp2)) st.push_disp(s.max_disp2);
    st.n_fast += s.n_fast;
  }

  bool stable(const typename Integrator::DriftStats& st) const {
    const double lim = max_step_move();
    return st.max_step2 <= lim * lim;
  }

  void check_stable(const typename Integrator::DriftStats& st) const {
    if (stable(st)) return;
    // Find the culprit (only on failure).
    std::size_t worst = 0;
    double worst_v = -1.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double s = p.v[i].squaredNorm();
      if (!std::isfinite(s) || !std::isfinite(p.x[i].squaredNorm())) { worst = i; worst_v = s; break; }
      if (s > worst_v) { worst = i; worst_v = s; }
    }
    std::ostringstream os;
    const double moved = std::sqrt(worst_v) * integrator.dt;
    os << "simulation unstable at step " << step_count + 1 << " (t = " << time + integrator.dt << "): particle id "
       << p.id[worst] << " ";
    if (!std::isfinite(worst_v) || !std::isfinite(p.x[worst].squaredNorm()))
      os << "has a non-finite position or velocity";
    else if (moved > 0.5 * d_min_)
      os << "moved " << moved << " in one step, more than half the smallest diameter (" << 0.5 * d_min_
         << "): collisions are not resolved; speed " << std::sqrt(worst_v);
    else
      os << "moves at " << std::sqrt(worst_v) << ", faster than anything in the scene drives it (" << speed_sources
         << ", limit " << max_speed << "): energy is growing without a source";
    os << ". " << (stability_hint.empty() ? "Reduce integrator.dt or check the contact parameters."
                                          : "Likely cause: " + stability_hint + ".");
    throw UnstableError(os.str());
  }

  NeighborList<Dim> nl_;
  double d_min_ = std::numeric_limits<double>::infinity();  // smallest diameter (the step-move limit)
  std::vector<Column<V>> fbuf_;
  std::vector<Column<A>> tbuf_;
  std::vector<PairBatch<Dim>> batch_;  // per thread, for laws with a batch kernel
  std::vector<Done> done_;             // per thread, see Gate
  long seq_ = 0;                       // the steps taken by this object, for Done
  long gen_ = 0;                       // the last claim number handed out (Claim)
  StealChoice steal_choice_;  // changed between regions, by the master thread only
  std::vector<Column<V>> task_f_;  // per tail task (NeighborList::tail_offsets)
  std::vector<Column<A>> task_t_;
  std::vector<Claim> claims_;  // per tail task
};

}  // namespace granular
