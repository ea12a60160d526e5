// Cell list by counting sort (count per cell, exclusive scan, scatter), after
// Cabana's LinkedCellList. Cells are at least `min_cell` wide, so every pair
// closer than min_cell lies in the same or an adjacent cell. Particles wider
// than `d_large` (a few, much larger than the rest: the big disk of the
// shaken box) go to one extra bucket, large(), so that the cells can be
// sized for the others (neighbor_list.hpp). The bucket sits at the end of the
// store, after every cell, or at its start when the large particles lie (on
// average) among the first half of the others in cell order: then a large
// particle's row, which reads every particle within its reach, reads
// particles of its own thread's block (the first block is the start of the
// store, the last its end) instead of reaching across the store to the other
// end. In the shaken box the big disk starts at the bottom; at the end of
// the store its row was the top block's only one that read the bottom block,
// and both threads then paid for each other's lines every step.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/domain.hpp"
#include "core/column.hpp"
#include "core/threads.hpp"

namespace granular {

template <int Dim>
class CellList {
 public:
  using V = Vec<Dim>;

  // Called by every thread of an OpenMP parallel region with its own block
  // [lo, hi): a parallel counting sort (per-thread histograms, a scan over
  // cells and threads, per-thread scatter). Particles keep their index order
  // within a cell, so the result is the same for any thread count. The scan
  // runs in parallel too, each thread over its own range of cells from the
  // sum of the ranges before it: run by one thread it was a serial pass over
  // every cell and every thread's histogram, nt times the cells (1.3·10⁶
  // entries for #T's 80 000 cells on 16 threads), repeated at every build.
  template <Wrap W>
  void build_in_region(const Domain<Dim, W>& domain, const Column<V>& x, const Column<double>& d, double d_large,
                       double min_cell, int t, int nt, std::size_t lo, std::size_t hi) {
    const std::size_t n = x.size();
#pragma omp single
    {
      const V len = domain.length();
      // Axis order: the axis with most cells varies slowest, so contiguous
      // index ranges (and the threads that own them) are slabs along the
      // longest axis.
      for (int k = 0; k < Dim; ++k) {
        int m = std::max(1, static_cast<int>(len[k] / min_cell));
        // A periodic axis with 2 cells would visit its neighbour twice.
        if (domain.periodic[k] && m < 3) m = 1;
        n_[k] = m;
        width_[k] = len[k] / m;
        order_[k] = k;
      }
      std::sort(order_.begin(), order_.end(), [&](int a, int b) { return n_[a] < n_[b]; });
      stride_[order_[0]] = 1;
      for (int q = 1; q < Dim; ++q) stride_[order_[q]] = stride_[order_[q - 1]] * n_[order_[q - 1]];
      n_cells_ = stride_[order_[Dim - 1]] * n_[order_[Dim - 1]];
      periodic_ = domain.periodic;
      len_ = len;
      lo_ = domain.lo;
      cell_tmp_.resize(n);
      cell_of_.resize(n);
      sorted_.resize(n);
      cell_start_.assign(n_cells_ + 1, 0);  // the cells and the end of the last
      offset_.resize(nt);
      large_cells_.resize(nt);
      range_count_.resize(nt);
      range_start_.resize(nt);
    }  // implicit barrier
    auto& count = offset_[t];
    count.assign(n_cells_ + 1, 0);
    // The large particles' cells (had they been small), summed: where the bucket goes.
    std::uint64_t large_cells = 0;
    for (std::size_t i = lo; i < hi; ++i) {
      const int c = cell_index(domain, x[i]);
      const bool large = d[i] > d_large;
      cell_tmp_[i] = large ? n_cells_ : c;
      large_cells += large ? static_cast<std::uint64_t>(c) : 0;
      ++count[cell_tmp_[i]];
    }
    large_cells_[t] = large_cells;
    // Each cell's entries, thread by thread, from `run` on: offset_[u][c]
    // becomes where thread u's particles of cell c start.
    const auto place = [&](int c, std::uint32_t& run) {
      for (int u = 0; u < nt; ++u) {
        const std::uint32_t k = offset_[u][c];
        offset_[u][c] = run;
        run += k;
      }
    };
    // Thread t's range of cells, and the particles in it.
    const auto [c0, c1] = thread_block(static_cast<std::size_t>(n_cells_), nt, t);
#pragma omp barrier
    {
      std::uint32_t in_range = 0;
      for (std::size_t c = c0; c < c1; ++c)
        for (int u = 0; u < nt; ++u) in_range += offset_[u][c];
      range_count_[t] = in_range;
    }
#pragma omp barrier
#pragma omp single
    {
      std::uint64_t n_large = 0, sum = 0;
      for (int u = 0; u < nt; ++u) {
        n_large += offset_[u][n_cells_];
        sum += large_cells_[u];
      }
      const bool large_first = n_large > 0 && 2 * sum < n_large * median_cell(n - n_large, nt);
      std::uint32_t run = large_first ? static_cast<std::uint32_t>(n_large) : 0;
      for (int u = 0; u < nt; ++u) {
        range_start_[u] = run;
        run += range_count_[u];
      }
      cell_start_[n_cells_] = run;
      large_begin_ = large_first ? 0 : run;
      std::uint32_t large_run = large_begin_;
      place(n_cells_, large_run);
      large_end_ = large_run;
    }  // implicit barrier
    {
      std::uint32_t run = range_start_[t];
      for (std::size_t c = c0; c < c1; ++c) {
        cell_start_[c] = run;
        place(static_cast<int>(c), run);
      }
    }
#pragma omp barrier
    for (std::size_t i = lo; i < hi; ++i) sorted_[count[cell_tmp_[i]]++] = static_cast<std::uint32_t>(i);
#pragma omp barrier
    // After the store is reordered by sorted(), particle k sits at slot k.
    for (std::size_t k = lo; k < hi; ++k) cell_of_[k] = cell_tmp_[sorted_[k]];
  }

  // Particle indices in cell order (a permutation: use it to reorder the store).
  const std::vector<std::uint32_t>& sorted() const { return sorted_; }
  int n_cells() const { return n_cells_; }
  // The bucket of the large particles (cell_of() for them): the store's
  // slots [large_begin(), large_end()), at its start or its end (above).
  int large() const { return n_cells_; }
  std::uint32_t large_begin() const { return large_begin_; }
  std::uint32_t large_end() const { return large_end_; }
  // The slots of cell c (not the large bucket).
  std::uint32_t begin(int c) const { return cell_start_[c]; }
  std::uint32_t end(int c) const { return cell_start_[c + 1]; }
  // Cell of the particle at slot k of the reordered store.
  int cell_of(std::size_t k) const { return cell_of_[k]; }

  // Half stencil of cell c: c itself plus the adjacent cells whose offset is
  // lexicographically positive in the store's axis order (the slowest axis
  // most significant, the axis of stride 1 least), with periodic wrap. So a
  // row never reaches into an earlier slab along the slowest axis: a
  // thread's block (a run of slabs) lists pairs outside itself only from its
  // last slab, and the rows before that read only its own particles
  // (NeighborList::own_end), which it evaluates while the other threads
  // finish their first stage. The cells of offsets one apart along the
  // stride-1 axis are consecutive in the store, so the 14 cells of a 3D half
  // stencil merge into 5 runs (the neighbour build's scan) where no axis
  // wraps. Visiting (c, c') for c' in
  // half_stencil(c) meets every pair of adjacent cells exactly once (periodic
  // axes have >= 3 cells or are collapsed to 1). Returns the count; out[0] = c.
  // shift[s]: what the wrap moved cell s by, so that x_j + shift[s] is the image
  // of a particle of cell s next to cell c, and (x_i - x_j) - shift[s] its
  // minimum-image separation (bitwise what Box::min_image gives, without its
  // three roundings), unless collapsed_periodic() (then use min_image).
  int half_stencil(int c, std::array<int, 14>& out, std::array<V, 14>& shift) const {
    std::array<int, Dim> ci{};
    for (int k = 0; k < Dim; ++k) ci[k] = (c / stride_[k]) % n_[k];
    int count = 0;
    const int total = Dim == 3 ? 27 : 9;
    for (int s = total / 2; s < total; ++s) {  // s = 13 (3D) / 4 (2D) is the zero offset
      int t = s;
      bool ok = true;
      int idx = 0;
      V sh = V::Zero();
      for (int digit = 0; digit < Dim; ++digit) {
        const int k = order_[digit];  // the axis of s's digit: the digit-th smallest stride
        const int off = t % 3 - 1;
        t /= 3;
        if (n_[k] == 1 && off != 0) { ok = false; break; }
        int q = ci[k] + off;
        if (q < 0 || q >= n_[k]) {
          if (!periodic_[k]) { ok = false; break; }
          sh[k] = q < 0 ? -len_[k] : len_[k];
          q = (q + n_[k]) % n_[k];
        }
        idx += q * stride_[k];
      }
      if (ok) {
        shift[count] = sh;
        out[count++] = idx;
      }
    }
    return count;
  }
  // f(c) once for every cell c that can hold a particle within `reach` of
  // position xc (each cell once, with periodic wrap): the full neighbourhood a
  // large particle searches. Separations must be taken with Box::min_image.
  template <class F>
  void for_cells_within(const V& xc, double reach, F&& f) const {
    std::array<int, Dim> first{}, count{}, q{};
    for (int k = 0; k < Dim; ++k) {
      const int c = std::clamp(static_cast<int>(std::floor((xc[k] - lo_[k]) / width_[k])), 0, n_[k] - 1);
      const int r = static_cast<int>(std::ceil(reach / width_[k]));
      if (periodic_[k] && 2 * r + 1 >= n_[k]) {
        first[k] = 0;
        count[k] = n_[k];
      } else if (periodic_[k]) {
        first[k] = c - r;
        count[k] = 2 * r + 1;
      } else {
        first[k] = std::max(0, c - r);
        count[k] = std::min(n_[k] - 1, c + r) - first[k] + 1;
      }
    }
    // An odometer over the Dim ranges.
    while (true) {
      int idx = 0;
      for (int k = 0; k < Dim; ++k) idx += ((first[k] + q[k] + n_[k]) % n_[k]) * stride_[k];
      f(idx);
      int k = 0;
      while (k < Dim && ++q[k] == count[k]) q[k++] = 0;
      if (k == Dim) break;
    }
  }

  // A periodic axis too short for three cells: pairs may meet across it
  // within one cell, and only Box::min_image finds the nearest image.
  bool collapsed_periodic() const {
    for (int k = 0; k < Dim; ++k)
      if (periodic_[k] && n_[k] == 1) return true;
    return false;
  }

 private:
  template <Wrap W>
  int cell_index(const Domain<Dim, W>& domain, const V& p) const {
    int idx = 0;
    for (int k = 0; k < Dim; ++k) {
      int q = static_cast<int>(std::floor((p[k] - domain.lo[k]) / width_[k]));
      // Particles a little outside a non-periodic edge (pressed into a wall)
      // belong to the edge cell; a wrapped periodic coordinate is inside anyway.
      q = std::clamp(q, 0, n_[k] - 1);
      idx += q * stride_[k];
    }
    return idx;
  }

  // The cell by which half of the n_small particles in cells come, from the
  // per-thread counts: twice its index plus one (twice its middle, to
  // compare with twice the large particles' mean cell).
  std::uint64_t median_cell(std::uint64_t n_small, int nt) const {
    std::uint64_t acc = 0;
    for (int c = 0; c < n_cells_; ++c) {
      for (int u = 0; u < nt; ++u) acc += offset_[u][c];
      if (2 * acc >= n_small) return 2 * static_cast<std::uint64_t>(c) + 1;
    }
    return 2 * static_cast<std::uint64_t>(n_cells_);
  }

  std::array<int, Dim> n_{};
  std::array<int, Dim> stride_{};
  std::array<int, Dim> order_{};
  std::array<bool, Dim> periodic_{};
  V width_ = V::Zero();
  V len_ = V::Zero();
  V lo_ = V::Zero();
  int n_cells_ = 0;
  std::vector<int> cell_of_, cell_tmp_;
  std::vector<std::vector<std::uint32_t>> offset_;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint64_t> large_cells_;  // per thread: see build_in_region
  std::vector<std::uint32_t> range_count_, range_start_;  // per thread: its range of cells' particles, and their first slot
  std::uint32_t large_begin_ = 0, large_end_ = 0;
  std::vector<std::uint32_t> sorted_;
};

}  // namespace granular
