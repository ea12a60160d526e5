// The time step, readable top to bottom (advance). The contact law,
// integrator and walls are template parameters: the scene layer picks them
// once and the per-contact loop contains no dispatch. The threads' meetings,
// ghost buffers and tail tasks are engine/parallel/thread_team.hpp's.
#pragma once
#include <omp.h>

#include <algorithm>
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
#include "core/particles.hpp"
#include "engine/parallel/thread_team.hpp"
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
  using Stats = typename Integrator::DriftStats;
  using Team = ThreadTeam<Dim, Stats>;
  static constexpr int kDim = Dim;

  // Whether W is among the walls.
  template <class W>
  static constexpr bool kHasWall = (false || ... || std::is_same_v<W, Walls>);
  // A periodic domain only with the PeriodicAxes boundary (core/domain.hpp).
  static constexpr bool kPeriodic = kHasWall<PeriodicAxes>;
  ParticleStore<Dim> p;
  Domain<Dim, kPeriodic ? Wrap::periodic : Wrap::open> domain;
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

  // n steps. A step's phases, in order, with the timer (PhaseTimers) each
  // goes to:
  //   1. first stage: the integrator's first stage on each thread's block,
  //      each piece's forces then started from the walls' (integrate, walls);
  //   2. neighbours: whether the list still holds every pair in range, from
  //      every thread's drift statistics; if not, it is rebuilt (neighbor);
  //   3. pair forces (pairs);
  //   4. ghost and tail sums: each thread adds to its block the shares that
  //      the other threads and the tail tasks computed for it (pairs);
  //   5. second stage (integrate);
  //   6. observers: the caller's, between two calls (observe, in the run
  //      loops). The caller picks n so that nothing reads the state in
  //      between (engine/run_control.hpp, next_stop).
  // Only the master thread's clock runs; its laps are the step's figures.
  //
  // Between neighbour-list rebuilds the steps run in one parallel region (a
  // stretch): every thread moves its own block, evaluates its block's pairs
  // and finishes it, meeting the others once a step (4), and goes straight on
  // to its next step. Between the first stage and the pairs there is no
  // barrier: each thread publishes its drift statistics and goes on with the
  // rows that read only its own particles while the others finish (2 is
  // decided during 3: engine/parallel/thread_team.hpp, Gate). Nor between one
  // step's second stage and the next step's first stage, which run as one
  // pass over the block (second_then_first: each particle's columns read and
  // written once, the same bits as the two stages apart): after the meeting
  // each thread reads and writes its own block only, until the next step's
  // gate, which every thread passes only once all have finished the step
  // before. A step whose verdict is to rebuild ends the region; the list is
  // rebuilt, and the rest of that step runs in a region of its own.
  void advance(long n) {
    const int nt = omp_get_max_threads();
    const double dt = integrator.dt;
    while (n > 0) {
      if (nt != nl_.threads()) rebuild();  // the thread count changed since the last build
      prepare(nt);
      const auto stretch = team_.open_stretch(n);
      const auto& xref = nl_.reference_positions();
      // Written by the master: the steps completed, the time after them, and
      // for a step that ends the region to rebuild (completed < n), its
      // statistics.
      long completed = 0;
      double time_out = time;
      Stats st;
#pragma omp parallel num_threads(nt)
      {
        StepThread w = enter(time, true);
        // 1. First stage (of the stretch's first step).
        Stats drift = first_stage(w, w.tm + dt, [&](std::size_t a, std::size_t e, const Stats& seed) {
          return integrator.first_half(p, domain, xref, a, e, w.tm + dt, seed);
        });
        long k = 0;
        for (; k < n; ++k) {
          // 2. Neighbours: the thread publishes its drift statistics and goes
          // on; the verdict comes during the pairs, the same on every thread.
          Gate g = team_.publish(w.t, stretch.seq(k), drift);
          w.laps.lap(Phase::integrate);
          // 3. Pair forces, until a verdict to rebuild ends the region.
          if (!pair_forces(w, stretch.gen(k), &g)) {
            if (w.t == 0) st = g.all;
            break;
          }
          // 4. Ghost and tail sums.
          ghost_sums(w, &g);
          w.tm += dt;
          // 5. Second stage, in one pass with the next step's first stage
          // (1) but after the stretch's last step.
          if (k + 1 == n) {
            second_stage(w);
            ++k;
            break;
          }
          drift = first_stage(w, w.tm + dt, [&](std::size_t a, std::size_t e, const Stats& seed) {
            return integrator.second_then_first(p, domain, xref, a, e, w.tm + dt, seed);
          });
        }
        if (w.t == 0) {
          completed = k;
          time_out = w.tm;
          w.laps.add_to(timers);
        }
      }
      timers.tails_taken += team_.collect_taken();
      time = time_out;
      step_count += completed;
      n -= completed;
      long steps = completed;
      if (n > 0) {
        // 2. Neighbours, for the step whose verdict was to rebuild (its first
        // stage is done): the list is rebuilt from the moved positions.
        check_stable(st);  // throws if unstable
        {
          ScopedPhase ph(timers, Phase::neighbor);
          rebuild(false);
        }
        const long gen = team_.evaluation();
#pragma omp parallel num_threads(nt)
        {
          StepThread w = enter(time, true);
          // The rebuild reordered the particles, not their forces: the walls'
          // again (1), then 3 to 5 of the step.
          walls_only(w, w.tm + dt);
          pair_forces(w, gen, nullptr);
          ghost_sums(w, nullptr);
          second_stage(w);
          if (w.t == 0) w.laps.add_to(timers);
        }
        timers.tails_taken += team_.collect_taken();
        time += dt;
        ++step_count;
        --n;
        ++steps;
      }
      team_.close_stretch(stretch, steps, timers);
    }
    // 6. Observers: the caller's, now that the n steps are taken.
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
    team_.after_build(nl_);
  }

  // A particle's work in a step besides its pairs, in listed pairs (the
  // threads' blocks balance it, neighbor/neighbor_list.hpp): its ghost sums,
  // its integration and the walls' checks, as each declares.
  static constexpr std::uint32_t kParticleWeight = 1 + Integrator::kWeight + (0 + ... + Walls::kWeight);

  // Forces at the current state (no integration); used at start-up.
  void compute_forces() {
    const int nt = omp_get_max_threads();
    if (nt != nl_.threads()) rebuild();
    prepare(nt);
    const long gen = team_.evaluation();
#pragma omp parallel num_threads(nt)
    {
      StepThread w = enter(time, false);
      walls_only(w, w.tm);
      pair_forces(w, gen, nullptr);
      ghost_sums(w, nullptr);
    }
    timers.tails_taken += team_.collect_taken();
  }

  const NeighborList<Dim>& neighbors() const { return nl_; }

  // The threads of the step: tests fix through it whether a free thread takes
  // other blocks' tail tasks, and stall a thread.
  Team& team() { return team_; }

  // Unstable if any particle moved further in one step than half the smallest
  // diameter (a collision passes in one or two steps, unresolved: Eq. (1)
  // diverges or grains pass through each other), faster than anything drives
  // it, or if anything is not finite. The neighbour list sets no limit here:
  // advance() rebuilds it from the current positions whenever the two largest
  // displacements since the last build exceed the skin, before any force is
  // evaluated, so it holds every pair in range however far a particle moved.
  double max_step_move() const { return std::min(0.5 * d_min_, max_speed * integrator.dt); }

  // Throws the UnstableError a step that moved a particle further than
  // max_step_move (or made one's state not finite) raises, naming the
  // culprit from the current state, which is that step's after its first
  // stage, before it is counted. For a state stepped elsewhere (the GPU
  // path, gpu/stepper_driver.hpp) that found the step unstable.
  [[noreturn]] void report_unstable_step() const {
    Stats st;
    st.max_step2 = std::numeric_limits<double>::infinity();
    check_stable(st);
    throw std::logic_error("report_unstable_step: the state is stable");
  }

 private:
  using Gate = typename Team::Gate;

  // The smallest diameter, for the step-move limit.
  void set_d_min() {
    d_min_ = std::numeric_limits<double>::infinity();
    for (double d : p.d) d_min_ = std::min(d_min_, d);
  }

  // Before a parallel region of nt threads opens: the team's records and
  // buffers, and the contact batches.
  void prepare(int nt) {
    team_.prepare(nt, p.size(), max_fast());
    if constexpr (HasPairBatch<Law, Dim>::value)
      if (static_cast<int>(batch_.size()) != nt) batch_.resize(nt);
  }

  // A thread of a parallel region: its number, the particles it owns (its
  // block [lo, hi): NeighborList::block), the time of the state it moves
  // (every thread sums it as the master does: the same bits) and the
  // stopwatch of the step's phases (the master's alone runs, when timed).
  struct StepThread {
    int t;
    std::size_t lo, hi;
    double tm;
    PhaseLaps laps;
  };
  StepThread enter(double tm, bool timed) const {
    const int t = omp_get_thread_num();
    const auto [lo, hi] = nl_.block(t);
    return StepThread{t, lo, hi, tm, PhaseLaps(timed && t == 0)};
  }

  // 1. A first stage (stage(a, e, seed): the integrator's, on particles
  // [a, e), its drift statistics continued from seed) over thread w's block,
  // a piece at a time, each piece's forces then started from the walls' at
  // the moved positions (time t_pos) while its columns are in the core's
  // cache. In a separate pass after the pairs, the walls cost a
  // 10^5-particle drum 10 % of a step against 5 % at 10^4: each pass over its
  // columns came from memory (docs/speed_accuracy.md). The statistics are
  // those of one pass: the pieces go in order, each continuing the last, and
  // name the fast particles into the thread's buffer.
  template <class Stage>
  Stats first_stage(StepThread& w, double t_pos, Stage&& stage) {
    std::vector<std::uint32_t>& fast = team_.fast_buffer(w.t);
    Stats st = Stats::naming_fast(0.5 * skin, fast.data(), static_cast<std::uint32_t>(fast.size()));
    for (std::size_t a = w.lo; a < w.hi; a += kWallPiece) {
      const std::size_t e = std::min(w.hi, a + kWallPiece);
      st = stage(a, e, st);
      w.laps.lap(Phase::integrate);
      start_with_walls(a, e, t_pos);
      w.laps.lap(Phase::walls);
    }
    return st;
  }
  // The walls' part of 1 alone, where no first stage has just done it.
  void walls_only(StepThread& w, double t_pos) {
    for (std::size_t a = w.lo; a < w.hi; a += kWallPiece) start_with_walls(a, std::min(w.hi, a + kWallPiece), t_pos);
    w.laps.lap(Phase::walls);
  }

  // Particles [a, e): forces and torques zeroed, then the walls' contacts
  // added (walls read and write the particles' own columns only).
  void start_with_walls(std::size_t a, std::size_t e, double t_pos) {
    std::fill(p.f.begin() + static_cast<std::ptrdiff_t>(a), p.f.begin() + static_cast<std::ptrdiff_t>(e), V::Zero());
    std::fill(p.tq.begin() + static_cast<std::ptrdiff_t>(a), p.tq.begin() + static_cast<std::ptrdiff_t>(e), A::Zero());
    std::apply([&](const auto&... w) { (w.apply(p, law, a, e, t_pos), ...); }, walls);
  }

  // 2. The step's verdict, from every thread's drift statistics combined:
  // go on with the list if every first stage stayed stable and within the
  // skin. Every thread runs it on the same published numbers: the same
  // verdict.
  bool list_holds(const Stats& all) const {
    return stable(all) && (all.disp_bound() <= skin || fast_pairs_listed(all));
  }

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
  bool fast_pairs_listed(const Stats& all) const {
    if (all.n_fast > max_fast() || !(all.max_disp2 <= skin * skin)) return false;
    return nl_.fast_pairs_listed(p, domain, std::sqrt(all.max_disp2), [&](auto&& f) { return team_.for_each_fast(f); });
  }

  // 3. Thread w's pairs: those of its block's core rows (NeighborList::core_end)
  // into its sinks (engine/parallel/ghost_forces.hpp), then tail tasks, its
  // block's and, while taking them pays, the other blocks'
  // (engine/parallel/tail_tasks.hpp). With a gate (straight after the first
  // stage) the rows that read another block, and the tail tasks, wait for the
  // verdict, and a verdict to rebuild stops the loop: then every thread
  // returns false, before the step's meeting, and the forces are recomputed
  // after the rebuild. Without one the caller knows the positions are final
  // everywhere. gen: a number larger than any earlier evaluation's, for the
  // tail tasks' claims.
  bool pair_forces(StepThread& w, long gen, Gate* gate) {
    const int t = w.t;
    const Sinks<Dim> sk = team_.sinks(t, w.lo, w.hi, p.f.data(), p.tq.data());
    if constexpr (HasPairBatch<Law, Dim>::value) batch_[t].n = 0;
    const auto go_on = [this](const Stats& all) { return list_holds(all); };
    // The core rows in pieces, each as far as the gate lets the thread go.
    auto walk = team_.core_walk(t, nl_, gate, go_on);
    nl_.for_row_segments(w.lo, nl_.core_end(t), [&](std::size_t a, std::size_t e, const std::uint32_t* col) {
      for (std::size_t r = a; r < e && !walk.stop();) {
        const std::size_t r1 = walk.until(r, e);
        if (walk.stop()) return;
        pairs(t, col, r, r1, sk);
        r = r1;
      }
    });
    if (walk.stop()) return false;
    flush_pairs(t, sk);
    if (!team_.verdict(gate, go_on)) return false;
    team_.run_tails(t, gen, [&](int u, int k) { tail_task(t, u, k); });
    return true;
  }
  // Thread t evaluates tail task k of block u into the task's buffer.
  void tail_task(int t, int u, int k) {
    const TaskSinks<Dim> sk = team_.task_sinks(u, k, nl_);
    const auto [a, e] = nl_.tail(u, k);
    nl_.for_row_segments(a, e,
                         [&](std::size_t r, std::size_t re, const std::uint32_t* col) { pairs(t, col, r, re, sk); });
    flush_pairs(t, sk);
  }

  // 4. Thread w meets the others once all have finished their pairs (at the
  // gate's step, or at a barrier without one) and adds to its block the
  // shares they and the tail tasks computed for it, in a fixed order.
  void ghost_sums(StepThread& w, const Gate* gate) {
    team_.meet_and_sum(w.t, w.lo, w.hi, nl_, gate, p.f.data(), p.tq.data());
    w.laps.lap(Phase::pairs);
  }

  // 5. The second stage on thread w's block.
  void second_stage(StepThread& w) {
    integrator.second_half(p, domain, w.lo, w.hi);
    w.laps.lap(Phase::integrate);
  }

  // Particles per piece of a first stage and the walls (first_stage): their
  // forces and torques, 24 kB in 3D, stay in the core's first-level cache.
  static constexpr std::size_t kWallPiece = 512;

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

  bool stable(const Stats& st) const {
    const double lim = max_step_move();
    return st.max_step2 <= lim * lim;
  }

  void check_stable(const Stats& st) const {
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
  std::vector<PairBatch<Dim>> batch_;                       // per thread, for laws with a batch kernel
  Team team_;
};

}  // namespace granular
