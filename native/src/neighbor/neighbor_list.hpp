// Half Verlet list in CSR form (row offsets / columns), after ExaMiniMD's
// NeighListCSR. Each pair within range(d_i, d_j) + skin is listed once. The list
// stays valid until two particles can have closed the skin (see leapfrog.hpp).
#pragma once
#include <omp.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "core/particles.hpp"
#include "core/threads.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/range_scan.hpp"

namespace granular {

template <int Dim>
class NeighborList {
 public:
  using V = Vec<Dim>;
  // Granularity at which a thread records which particles outside its own
  // block it writes forces to (in its ghost buffer), so that only those
  // entries are zeroed and reduced. 16 particles: a 2D chunk's forces and
  // torques are 6 cache lines, so the ghosts that cross between cores are
  // little more than the ~45 boundary particles of the shaken box (64 read
  // up to 3 times as many lines; box 3 Hz, 2 threads, docs/speed_accuracy.md).
  static constexpr std::size_t kChunk = 16;
  // The work of a particle's forces in units of one listed pair that is not
  // in contact (a distance test), for balancing the threads' blocks: a pair
  // in contact costs kContactWeight more. Per-thread timers in the shaken box
  // (P-H law) give 1.9 ns a listed pair and 17.5 ns a contact, about 9; but
  // the blocks balance best at 5, where the top block's dilute rows (many
  // listed pairs, few contacts) weigh more than the timers' split says. Box
  // 3 Hz, 2 threads, 6 interleaved rounds: 5.31 against 5.11·10⁷
  // particle-steps/s at 9; drum #A the same within its rounds' spread
  // (docs/speed_accuracy.md, "The threads' blocks"). The particle's own share (its
  // integration, walls and ghost sums) comes from the caller:
  // build(particle_weight).
  static constexpr std::uint32_t kContactWeight = 5;
  // Tail tasks. The last rows of each block are cut into kTails tasks of
  // kTailPercent of the block's expected work each. The owner evaluates them
  // after the rest of its block, and a thread that has finished its own block
  // takes the other blocks' tasks from the back (engine/parallel/tail_tasks.hpp): a
  // core that runs slower for a while (the speed of each of this machine's
  // virtual cores drifts by up to a third, independently) then leaves less of
  // the step to wait for. A task writes all its forces, its own particles'
  // too, into a buffer of its own that is summed in a fixed order, so the
  // result does not depend on which thread ran it.
  static constexpr int kTails = 3;
  static constexpr std::uint64_t kTailPercent = 8;
  // Rows whose columns the marking pass of a build tests at once (build()).
  static constexpr std::size_t kMarkRows = 16;

  // Sorts the store by cell (reorder), then lists pairs. The contact law's
  // interaction range is range_factor * (d_i + d_j) (every law's form,
  // contact/*.hpp kRangeFactor), so that the vector scan can test it lane by
  // lane (range_scan.hpp). particle_weight: a particle's work besides its
  // pairs (above). Thread t lists the rows of row_block(t) (equal particle
  // counts) into its own column array, so nothing is copied between threads. Then the store is cut
  // into the blocks the threads own for the step, block(t), of equal expected
  // work (balance()): in the shaken box the packed bottom has 1.75 times the
  // contacts of the fluidised top for the same number of particles, and equal
  // counts left one thread waiting a third of the pair loop for the other.
  // Every phase of the step uses block(t), the drift too, so a particle's
  // columns stay in one core's cache (a drift on equal counts moved the
  // columns of the particles between the two cuts across cores every step,
  // and made Gear's stages 1.5 times dearer per particle there).
  // forces = false: the caller recomputes f and tq before reading them, so
  // the reorder leaves them as they are.
  //
  // Size classes. A few particles much larger than the rest would set a cell
  // size far too large for the others: the shaken box's big disk (radius 4
  // among grains of radius 0.85-1.15) made 8.5-wide cells where 2.8 serve the
  // grains, and each grain's row tested 9 times the candidates it needs. If
  // no more than n / kLargeShare particles are wider than d_max / kLargeRatio,
  // they are large: the cells are sized for the others and leave the large
  // ones out (CellList::large(): a bucket at the start or the end of the
  // store, whichever is nearer the cells they lie in), and each large
  // particle lists all its pairs in its own row, from every cell within its
  // reach and the large ones after it.
  // The others' rows never meet a large particle. Otherwise (Rapaport's
  // drums, half big and half small) there is one class and nothing changes.
  static constexpr double kLargeRatio = 1.5;
  static constexpr std::size_t kLargeShare = 64;
  template <Wrap W>
  void build(ParticleStore<Dim>& p, const Domain<Dim, W>& domain, double skin, double range_factor,
             int exclude_species = -1, bool forces = true, std::uint32_t particle_weight = 1) {
    const auto range = [range_factor](double a, double b) { return range_factor * (a + b); };
    skin_ = skin;
    const std::size_t n = p.size();
    nt_ = omp_get_max_threads();
    col_.resize(nt_);
    touched_.resize(nt_);
    touched_list_.resize(nt_);
    own_end_.resize(nt_);
    row_begin_.resize(n);
    row_end_.resize(n);
    weight_.resize(n);
    work_.resize(nt_);
    x_ref_.resize(n);
    static_assert(sizeof(V) == Dim * sizeof(double), "pair_scan reads the positions as packed doubles");
    // The size classes (above): d_small is the largest diameter that is not
    // large. Eight running maxima and counts, which the compiler keeps in
    // vector lanes: one chain of maxima, each waiting for the last, took
    // the serial start of a build in the shaken box 4 us (docs/speed_accuracy.md,
    // "The neighbour list"). A maximum is exact in any order: the same classes.
    constexpr std::size_t kLanes = 8;
    const double* dp = p.d.data();
    std::array<double, kLanes> lane_max{}, lane_small{};
    std::array<std::uint64_t, kLanes> lane_large{};
    std::size_t k8 = 0;
    for (; k8 + kLanes <= n; k8 += kLanes)
      for (std::size_t q = 0; q < kLanes; ++q) lane_max[q] = dp[k8 + q] > lane_max[q] ? dp[k8 + q] : lane_max[q];
    double d_max = 0.0;
    for (double m : lane_max) d_max = std::max(d_max, m);
    for (std::size_t k = k8; k < n; ++k) d_max = std::max(d_max, dp[k]);
    double d_large = d_max / kLargeRatio, d_small = 0.0;
    for (std::size_t k = 0; k < k8; k += kLanes)
      for (std::size_t q = 0; q < kLanes; ++q) {
        const double dj = dp[k + q];
        lane_large[q] += dj > d_large;
        lane_small[q] = dj <= d_large && dj > lane_small[q] ? dj : lane_small[q];
      }
    std::size_t n_large = 0;
    for (std::size_t q = 0; q < kLanes; ++q) {
      n_large += lane_large[q];
      d_small = std::max(d_small, lane_small[q]);
    }
    for (std::size_t k = k8; k < n; ++k) {
      n_large += dp[k] > d_large;
      if (dp[k] <= d_large) d_small = std::max(d_small, dp[k]);
    }
    if (n_large == 0 || n_large * kLargeShare > n) {
      d_large = std::numeric_limits<double>::infinity();
      d_small = d_max;
    }
    n_large_ = d_large < d_max ? n_large : 0;
    d_max_ = d_max;
    range_factor_ = range_factor;
    exclude_species_ = exclude_species;
    const std::size_t n_chunks = (n + kChunk - 1) / kChunk;
    p.prepare_reorder();
#pragma omp parallel num_threads(nt_)
    {
      const int t = omp_get_thread_num();
      const auto [lo, hi] = thread_block(n, nt_, t);
      cells_.build_in_region(domain, p.x, p.d, d_large, range(d_small, d_small) + skin, t, nt_, lo, hi);
      p.reorder_in_parallel(cells_.sorted(), lo, hi, forces);
#pragma omp barrier
      auto& out = col_[t];
      std::size_t n_out = 0;
      std::uint64_t work = 0;
      std::array<int, 14> st{};
      std::array<V, 14> shift;
      // The stencil's cells merged into runs contiguous in the store: cells
      // next to each other along the axis of stride 1 hold consecutive
      // particles, so the 14 cells of a 3D half stencil make 5 runs.
      std::array<std::uint32_t, 14> run_b{}, run_e{};
      std::array<V, 14> run_shift;
      int n_runs = 0, cell = -1;
      const bool collapsed = cells_.collapsed_periodic();
      const std::int32_t* species = p.species.data();
      const double* d = p.d.data();
      const V* x = p.x.data();
      const double* xflat = reinterpret_cast<const double*>(x);
      // A large particle's row: every pair within range + skin, from the
      // cells within its reach (whatever the direction: no small particle's
      // row lists a large one) and the large particles after it. Few rows,
      // so the plain minimum-image test.
      const std::uint32_t large_end = cells_.large_end();
      // Room in out for k more columns (the vector scan stores whole vectors
      // past the last kept one).
      auto room = [&](std::uint32_t k) {
        if (out.size() < n_out + k + kScanSlack) out.resize(std::max(2 * out.size(), n_out + k + kScanSlack));
      };
      // Row i's pairs among [b, e) by the plain minimum-image test: for the
      // few large rows and a periodic axis of one cell (where only the
      // minimum image finds the nearest copy of j).
      auto scan_min_image = [&](std::size_t i, std::uint32_t b, std::uint32_t e, std::uint32_t& contacts) {
        const V xi = x[i];
        const double di = d[i];
        const bool excluded_i = species[i] == exclude_species;
        room(e - b);
        for (std::uint32_t j = b; j < e; ++j) {
          const double r0 = range(di, d[j]), rc = r0 + skin;
          const double r2 = domain.min_image(xi - x[j]).squaredNorm();
          const bool hit = (r2 < rc * rc) & !(excluded_i & (species[j] == exclude_species));
          out[n_out] = j;
          n_out += hit;
          contacts += hit & (r2 < r0 * r0);
        }
      };
      auto list_large = [&](std::size_t i) {
        std::uint32_t contacts = 0;
        cells_.for_cells_within(x[i], range(d[i], d_small) + skin,
                                [&](int c) { scan_min_image(i, cells_.begin(c), cells_.end(c), contacts); });
        scan_min_image(i, static_cast<std::uint32_t>(i + 1), large_end, contacts);
        return contacts;
      };
      // A row of a particle of the cells: its half stencil, merged into runs.
      auto list_in_cells = [&](std::size_t i) {
        // The store is in cell order: the stencil changes only with the cell.
        if (cells_.cell_of(i) != cell) {
          cell = cells_.cell_of(i);
          const int ns = cells_.half_stencil(cell, st, shift);
          n_runs = 0;
          for (int s = 0; s < ns; ++s) {
            if (n_runs > 0 && st[s] == st[s - 1] + 1 && shift[s] == run_shift[n_runs - 1]) {
              run_e[n_runs - 1] = cells_.end(st[s]);
              continue;
            }
            run_b[n_runs] = cells_.begin(st[s]);
            run_e[n_runs] = cells_.end(st[s]);
            run_shift[n_runs++] = shift[s];
          }
        }
        const V xi = x[i];
        const double di = d[i];
        const bool excluded_i = species[i] == exclude_species;
        PairScanRow row{nullptr, di, range_factor, skin, excluded_i ? species : nullptr, exclude_species};
        std::uint32_t contacts = 0;
        for (int s = 0; s < n_runs; ++s) {
          // Own cell (the first run): only j > i; other runs: all of them.
          const std::uint32_t b = s == 0 ? static_cast<std::uint32_t>(i + 1) : run_b[s];
          const std::uint32_t e = run_e[s];
          if (b >= e) continue;
          if (collapsed) {
            scan_min_image(i, b, e, contacts);
            continue;
          }
          room(e - b);
          std::uint32_t* const o = out.data() + n_out;
          const V xs = xi - run_shift[s];
          row.xs = xs.data();
          n_out += static_cast<std::size_t>(pair_scan<Dim>(xflat, d, b, e, row, o, contacts) - o);
        }
        return contacts;
      };
      for (std::size_t i = lo; i < hi; ++i) {
        row_begin_[i] = static_cast<std::uint32_t>(n_out);
        const std::uint32_t contacts = cells_.cell_of(i) == cells_.large() ? list_large(i) : list_in_cells(i);
        row_end_[i] = static_cast<std::uint32_t>(n_out);
        x_ref_[i] = x[i];
        weight_[i] = row_end_[i] - row_begin_[i] + kContactWeight * contacts + particle_weight;
        work += weight_[i];
      }
      out.resize(n_out);
      work_[t] = work;
#pragma omp barrier
#pragma omp single
      {
        balance(n);
        cut_tails();
        tail_touched_.resize(static_cast<std::size_t>(nt_ * kTails));
        tail_list_.resize(static_cast<std::size_t>(nt_ * kTails));
        tail_offset_.resize(static_cast<std::size_t>(nt_ * kTails));
      }
      for (int k = 0; k < tails(); ++k) tail_touched_[static_cast<std::size_t>(t * kTails + k)].assign(n_chunks, 0);
      // Which chunks outside its block thread t's rows write to (one thread
      // owns every particle and writes no ghosts), and the first of its rows
      // that reads a particle of another block.
      const std::size_t blo = bounds_[t], bhi = bounds_[t + 1];  // block(t)
      const std::size_t core = core_end(t);
      auto& mark = touched_[t];
      mark.assign(n_chunks, 0);
      std::size_t own_end = bhi;
      if (nt_ > 1)
        for_row_segments(blo, bhi, [&](std::size_t a, std::size_t e, const std::uint32_t* c) {
          // The core's rows write the store for the block and a ghost buffer
          // for the rest: only a row that reads outside the block marks
          // anything. Most read inside it, which the smallest and largest
          // column of kMarkRows rows at a time tell (their columns are
          // contiguous in c) without a write: a vector reduction. Testing
          // the columns a row at a time (4.5 a row on the drum) cost the
          // drum's thread 0 25 us a build, 10 this way (docs/speed_accuracy.md,
          // "The neighbour list").
          const std::size_t core_e = std::min(e, core);
          for (std::size_t i = a; i < core_e;) {
            const std::size_t i1 = std::min(core_e, i + kMarkRows);
            std::uint32_t lo_c = std::numeric_limits<std::uint32_t>::max(), hi_c = 0;
            for (std::uint32_t k = row_begin_[i], ke = row_end_[i1 - 1]; k < ke; ++k) {
              lo_c = std::min(lo_c, c[k]);
              hi_c = std::max(hi_c, c[k]);
            }
            if (lo_c >= blo && hi_c < bhi) {
              i = i1;
              continue;
            }
            for (; i < i1; ++i) {
              bool out_i = false;
              for (std::uint32_t k = row_begin_[i], ke = row_end_[i]; k < ke; ++k)
                if (c[k] < blo || c[k] >= bhi) {
                  mark[c[k] / kChunk] = 1;
                  out_i = true;
                }
              if (out_i && own_end == bhi) own_end = i;
            }
          }
          // A tail task writes its buffer for all of its particles.
          for (std::size_t i = std::max(a, core); i < e; ++i) {
            auto& tm = tail_touched_[static_cast<std::size_t>(tail_of(t, i))];
            tm[i / kChunk] = 1;
            std::uint8_t out_i = 0;
            for (std::uint32_t k = row_begin_[i], ke = row_end_[i]; k < ke; ++k) {
              out_i |= static_cast<std::uint8_t>((c[k] < blo) | (c[k] >= bhi));
              tm[c[k] / kChunk] = 1;
            }
            if (out_i && own_end == bhi) own_end = i;
          }
        });
      own_end_[t] = own_end;
      chunk_list(mark, touched_list_[t]);
      for (int k = 0; k < tails(); ++k) {
        const std::size_t task = static_cast<std::size_t>(t * kTails + k);
        chunk_list(tail_touched_[task], tail_list_[task]);
        // The task's buffer holds its chunks one after another.
        auto& off = tail_offset_[task];
        off.assign(n_chunks, 0);
        const auto& list = tail_list_[task];
        for (std::size_t q = 0; q < list.size(); ++q)
          off[list[q]] = static_cast<std::int64_t>(q * kChunk) - static_cast<std::int64_t>(list[q] * kChunk);
      }
    }
    ++builds_;
  }

  int threads() const { return nt_; }
  // The particles whose rows thread t listed: row i of them is
  // col(t)[begin(i) .. end(i)).
  std::pair<std::size_t, std::size_t> row_block(int t) const { return thread_block(row_begin_.size(), nt_, t); }
  const std::uint32_t* col(int t) const { return col_[t].data(); }
  // The particles thread t owns in a step: it integrates them, evaluates their
  // rows and sums their forces.
  std::pair<std::size_t, std::size_t> block(int t) const { return {bounds_[t], bounds_[t + 1]}; }
  // f(a, b, col) for the pieces [a, b) of block(t) listed by one thread, in
  // order: a block spans at most a few row blocks. The rows of a piece are
  // contiguous in col: col[begin(a) .. end(b - 1)).
  template <class F>
  void for_row_segments(int t, F&& f) const {
    const auto [lo, hi] = block(t);
    for_row_segments(lo, hi, f);
  }
  // The same for any rows [lo, hi).
  template <class F>
  void for_row_segments(std::size_t lo, std::size_t hi, F&& f) const {
    for (int u = 0; u < nt_; ++u) {
      const auto [rlo, rhi] = row_block(u);
      const std::size_t a = std::max(lo, rlo), b = std::min(hi, rhi);
      if (a < b) f(a, b, col(u));
    }
  }
  std::uint32_t begin(std::size_t i) const { return row_begin_[i]; }
  std::uint32_t end(std::size_t i) const { return row_end_[i]; }
  // Whether thread t writes force entries of particles outside its block in
  // chunk c (particles c*kChunk ...).
  bool touched(int t, std::size_t c) const { return touched_[t][c] != 0; }
  // The chunks thread t writes outside its block, in order.
  const std::vector<std::uint32_t>& touched_chunks(int t) const { return touched_list_[t]; }
  // The rows of block(t) before own_end(t) read only particles of block(t):
  // thread t can evaluate them as soon as it has moved its own particles
  // (the block's end when no row reads another block, as on one thread).
  std::size_t own_end(int t) const { return own_end_[t]; }
  // Tail tasks (kTails above; none on one thread): block(t) is its core
  // [block(t).first, core_end(t)) and then tail(t, 0), ..., tail(t, kTails - 1).
  int tails() const { return nt_ > 1 ? kTails : 0; }
  std::size_t core_end(int t) const { return tails() ? tail_begin_[tail_index(t, 0)] : bounds_[t + 1]; }
  std::pair<std::size_t, std::size_t> tail(int t, int k) const {
    return {tail_begin_[tail_index(t, k)], tail_begin_[tail_index(t, k) + 1]};
  }
  // Which chunks task t * kTails + k writes (its buffer), as flags and in order.
  bool tail_touched(std::size_t task, std::size_t c) const { return tail_touched_[task][c] != 0; }
  const std::vector<std::uint32_t>& tail_chunks(std::size_t task) const { return tail_list_[task]; }
  // A task's buffer holds only the chunks it writes, in the order of
  // tail_chunks(): particle j's entry is at tail_offsets(task)[j / kChunk] + j.
  const std::int64_t* tail_offsets(std::size_t task) const { return tail_offset_[task].data(); }
  std::size_t n_pairs() const {
    std::size_t k = 0;
    for (const auto& c : col_) k += c.size();
    return k;
  }
  double skin() const { return skin_; }
  // Particles in the large class at the last build (0: one class).
  std::size_t n_large() const { return n_large_; }
  long builds() const { return builds_; }
  const Column<V>& reference_positions() const { return x_ref_; }

  // Whether every pair in range now is listed, once the two largest
  // displacements since the build add up to more than the skin
  // (integrate/drift_stats.hpp). A pair of two particles that each moved at
  // most skin/2 was listed if it is in range now; every other pair involves a
  // fast particle, one that moved more than skin/2. for_each_fast(f) calls
  // f(i) for every fast particle i (and stops when f returns false);
  // disp_max is the largest displacement of any particle. Each pair of a fast
  // particle in range now (the build's range factor times d_i + d_j, pairs
  // of two excluded particles left out as the build leaves them) is tested
  // against the build's own rule: listed if closer than range + skin at the
  // reference positions. Both tests leave a margin of 1e-9 for rounding (the build's
  // separations come from shifted positions, not Box::min_image), so that a
  // pair on the edge counts as unlisted and calls for a rebuild. The
  // candidates come from the build's cells within reach: a particle within
  // range of x_i now was within range + disp_max of it at the build.
  template <class ForEachFast, Wrap W>
  bool fast_pairs_listed(const ParticleStore<Dim>& p, const Domain<Dim, W>& domain, double disp_max,
                         ForEachFast&& for_each_fast) const {
    constexpr double kMargin = 1e-9;
    const double range_factor = range_factor_;
    const int exclude_species = exclude_species_;
    const std::uint32_t lb = cells_.large_begin(), le = cells_.large_end();
    return for_each_fast([&](std::uint32_t i) {
      const V xi = p.x[i], ri = x_ref_[i];
      const double di = p.d[i];
      const bool excluded_i = p.species[i] == exclude_species;
      bool ok = true;
      auto test = [&](std::uint32_t b, std::uint32_t e) {
        for (std::uint32_t j = b; j < e && ok; ++j) {
          if (j == i || (excluded_i && p.species[j] == exclude_species)) continue;
          const double r0 = range_factor * (di + p.d[j]);
          if (domain.min_image(xi - p.x[j]).squaredNorm() >= (1.0 + kMargin) * (r0 * r0)) continue;
          const double rl = r0 + skin_;
          ok = domain.min_image(ri - x_ref_[j]).squaredNorm() < (1.0 - kMargin) * (rl * rl);
        }
      };
      cells_.for_cells_within(xi, range_factor * (di + d_max_) + disp_max, [&](int c) {
        if (ok) test(cells_.begin(c), cells_.end(c));
      });
      test(lb, le);
      return ok;
    });
  }

  // Pairs as (id_i, id_j) with id_i < id_j, sorted: for comparison with the oracle.
  std::vector<std::pair<std::int64_t, std::int64_t>> pairs_by_id(const ParticleStore<Dim>& p) const {
    std::vector<std::pair<std::int64_t, std::int64_t>> out;
    for (int t = 0; t < nt_; ++t) {
      const auto [lo, hi] = row_block(t);
      for (std::size_t i = lo; i < hi; ++i)
        for (std::uint32_t k = begin(i); k < end(i); ++k) {
          const auto a = p.id[i], b = p.id[col_[t][k]];
          out.emplace_back(std::min(a, b), std::max(a, b));
        }
    }
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  // Cuts the store into nt_ blocks of equal work (the weights of the rows
  // just listed): bounds_[k] is the first particle at which the running sum
  // reaches k / nt_ of the total. Integer sums, so the blocks depend on the
  // positions only: a rebuild from a checkpoint's reference positions
  // restores them exactly. Serial, but it skips whole row blocks and walks
  // one at most per cut.
  void balance(std::size_t n) {
    bounds_.assign(static_cast<std::size_t>(nt_) + 1, n);
    bounds_[0] = 0;
    std::uint64_t total = 0;
    for (int u = 0; u < nt_; ++u) total += work_[u];
    block_work_.assign(static_cast<std::size_t>(nt_), 0);
    std::size_t i = 0;
    std::uint64_t acc = 0;   // the weight of [0, i)
    std::uint64_t done = 0;  // the weight of the blocks cut so far
    for (int k = 1; k < nt_; ++k) {
      const std::uint64_t target = total * static_cast<std::uint64_t>(k) / static_cast<std::uint64_t>(nt_);
      for (int u = 0; u < nt_; ++u) {
        const auto [rlo, rhi] = row_block(u);
        if (rhi <= i || rlo == rhi) continue;
        if (rlo != i || acc + work_[u] >= target) break;
        acc += work_[u];
        i = rhi;
      }
      while (i < n && acc < target) acc += weight_[i++];
      // On a cache line of every column (core/column.hpp).
      while (i < n && i % kLineParticles != 0) acc += weight_[i++];
      bounds_[k] = i;
      block_work_[k - 1] = acc - done;
      done = acc;
    }
    block_work_[nt_ - 1] = total - done;
  }

  // Cuts the last rows of each block into its tail tasks (kTails above), of
  // kTailPercent of the block's work each, from the block's end back. Integer
  // sums of the same weights as balance(): the same positions give the same
  // tasks.
  void cut_tails() {
    tail_begin_.assign(static_cast<std::size_t>(nt_ * (kTails + 1)), 0);
    if (nt_ == 1) return;
    for (int t = 0; t < nt_; ++t) {
      const std::size_t lo = bounds_[t];
      std::size_t i = bounds_[t + 1];
      const std::uint64_t task_work = block_work_[t] * kTailPercent / 100;
      tail_begin_[tail_index(t, kTails)] = i;
      for (int k = kTails - 1; k >= 0; --k) {
        std::uint64_t acc = 0;
        while (i > lo && acc < task_work) acc += weight_[--i];
        tail_begin_[tail_index(t, k)] = i;
      }
    }
  }
  std::size_t tail_index(int t, int k) const { return static_cast<std::size_t>(t * (kTails + 1) + k); }
  // The task holding row i of block t's tail.
  int tail_of(int t, std::size_t i) const {
    int k = 0;
    while (k + 1 < kTails && i >= tail_begin_[tail_index(t, k + 1)]) ++k;
    return t * kTails + k;
  }
  static void chunk_list(const std::vector<std::uint8_t>& mark, std::vector<std::uint32_t>& list) {
    list.clear();
    for (std::size_t c = 0; c < mark.size(); ++c)
      if (mark[c]) list.push_back(static_cast<std::uint32_t>(c));
  }

  CellList<Dim> cells_;
  int nt_ = 1;
  std::vector<std::vector<std::uint32_t>> col_;
  std::vector<std::vector<std::uint8_t>> touched_;
  std::vector<std::vector<std::uint32_t>> touched_list_;  // per thread: see touched_chunks()
  std::vector<std::size_t> own_end_;  // per thread: see own_end()
  std::vector<std::uint32_t> row_begin_, row_end_;
  std::vector<std::uint32_t> weight_;  // per particle, for balance()
  std::vector<std::uint64_t> work_;    // per row block: the sum of its weights
  std::vector<std::size_t> bounds_{0, 0};  // block(t) = [bounds_[t], bounds_[t + 1])
  std::vector<std::uint64_t> block_work_;  // per block, from balance()
  std::vector<std::size_t> tail_begin_;   // per block, the kTails tasks' starts and the block's end
  std::vector<std::vector<std::uint8_t>> tail_touched_;  // per tail task: see tail_touched()
  std::vector<std::vector<std::uint32_t>> tail_list_;
  std::vector<std::vector<std::int64_t>> tail_offset_;  // per tail task: see tail_offsets()
  Column<V> x_ref_;
  double skin_ = 0.0;
  double d_max_ = 0.0;         // the largest diameter at the build
  double range_factor_ = 0.0;  // the build's range(d_i, d_j) / (d_i + d_j)
  int exclude_species_ = -1;   // the build's excluded species
  std::size_t n_large_ = 0;
  long builds_ = 0;
};

// O(N^2) oracle: every pair closer than range(d_i, d_j) + skin, by id.
template <int Dim, Wrap W, class RangeFn>
std::vector<std::pair<std::int64_t, std::int64_t>> brute_force_pairs(const ParticleStore<Dim>& p,
                                                                      const Domain<Dim, W>& domain, double skin,
                                                                      RangeFn range) {
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const double rc = range(p.d[i], p.d[j]) + skin;
      if (domain.min_image(p.x[i] - p.x[j]).squaredNorm() < rc * rc)
        out.emplace_back(std::min(p.id[i], p.id[j]), std::max(p.id[i], p.id[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace granular
