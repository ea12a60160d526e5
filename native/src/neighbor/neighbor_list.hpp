// Half Verlet list in CSR form (row offsets / columns), after ExaMiniMD's
// NeighListCSR. Each pair within range(d_i, d_j) + skin is listed once. The list
// stays valid until two particles can have closed the skin (see leapfrog.hpp).
#pragma once
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/particles.hpp"
#include "core/threads.hpp"
#include "neighbor/cell_list.hpp"

namespace granular {

template <int Dim>
class NeighborList {
 public:
  using V = Vec<Dim>;
  // Granularity at which a thread records which particles' force entries it
  // writes, so that only those are zeroed and reduced.
  static constexpr std::size_t kChunk = 64;

  // Sorts the store by cell (reorder), then lists pairs. RangeFn(d_i, d_j) is
  // the contact law's interaction range; a template, so it inlines. Thread t
  // owns the rows of its block thread_block(n, nt, t) and keeps them in its own
  // column array, so nothing is copied between threads.
  template <class RangeFn>
  void build(ParticleStore<Dim>& p, const Box<Dim>& box, double max_range, double skin, RangeFn range,
             int exclude_species = -1) {
    skin_ = skin;
    const std::size_t n = p.size();
    nt_ = omp_get_max_threads();
    col_.resize(nt_);
    touched_.resize(nt_);
    row_begin_.resize(n);
    row_end_.resize(n);
    x_ref_.resize(n);
    const std::size_t n_chunks = (n + kChunk - 1) / kChunk;
#pragma omp parallel num_threads(nt_)
    {
      const int t = omp_get_thread_num();
      const auto [lo, hi] = thread_block(n, nt_, t);
      cells_.build_in_region(box, p.x, max_range + skin, t, nt_, lo, hi);
      p.reorder_in_parallel(cells_.sorted(), lo, hi);
#pragma omp barrier
      auto& out = col_[t];
      auto& mark = touched_[t];
      out.clear();
      mark.assign(n_chunks, 0);
      std::array<int, 14> st{};
      for (std::size_t i = lo; i < hi; ++i) {
        row_begin_[i] = static_cast<std::uint32_t>(out.size());
        mark[i / kChunk] = 1;
        const int ns = cells_.half_stencil(cells_.cell_of(i), st);
        const V xi = p.x[i];
        const double di = p.d[i];
        const bool excluded_i = p.species[i] == exclude_species;
        for (int s = 0; s < ns; ++s) {
          // Own cell: only j > i; forward cells: all of them.
          const std::uint32_t b = s == 0 ? static_cast<std::uint32_t>(i + 1) : cells_.begin(st[s]);
          const std::uint32_t e = cells_.end(st[s]);
          for (std::uint32_t j = b; j < e; ++j) {
            if (excluded_i && p.species[j] == exclude_species) continue;
            const double rc = range(di, p.d[j]) + skin;
            if (box.min_image(xi - p.x[j]).squaredNorm() < rc * rc) {
              out.push_back(j);
              mark[j / kChunk] = 1;
            }
          }
        }
        row_end_[i] = static_cast<std::uint32_t>(out.size());
        x_ref_[i] = p.x[i];
      }
    }
    ++builds_;
  }

  int threads() const { return nt_; }
  // Row i (owned by thread t): col(t)[begin(i) .. end(i)).
  const std::uint32_t* col(int t) const { return col_[t].data(); }
  std::uint32_t begin(std::size_t i) const { return row_begin_[i]; }
  std::uint32_t end(std::size_t i) const { return row_end_[i]; }
  // Whether thread t writes force entries in chunk c (particles c*kChunk ...).
  bool touched(int t, std::size_t c) const { return touched_[t][c] != 0; }
  std::size_t n_pairs() const {
    std::size_t k = 0;
    for (const auto& c : col_) k += c.size();
    return k;
  }
  double skin() const { return skin_; }
  long builds() const { return builds_; }
  const std::vector<V>& reference_positions() const { return x_ref_; }

  // Pairs as (id_i, id_j) with id_i < id_j, sorted: for comparison with the oracle.
  std::vector<std::pair<std::int64_t, std::int64_t>> pairs_by_id(const ParticleStore<Dim>& p) const {
    std::vector<std::pair<std::int64_t, std::int64_t>> out;
    for (int t = 0; t < nt_; ++t) {
      const auto [lo, hi] = thread_block(p.size(), nt_, t);
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
  CellList<Dim> cells_;
  int nt_ = 1;
  std::vector<std::vector<std::uint32_t>> col_;
  std::vector<std::vector<std::uint8_t>> touched_;
  std::vector<std::uint32_t> row_begin_, row_end_;
  std::vector<V> x_ref_;
  double skin_ = 0.0;
  long builds_ = 0;
};

// O(N^2) oracle: every pair closer than range(d_i, d_j) + skin, by id.
template <int Dim, class RangeFn>
std::vector<std::pair<std::int64_t, std::int64_t>> brute_force_pairs(const ParticleStore<Dim>& p,
                                                                      const Box<Dim>& box, double skin,
                                                                      RangeFn range) {
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const double rc = range(p.d[i], p.d[j]) + skin;
      if (box.min_image(p.x[i] - p.x[j]).squaredNorm() < rc * rc)
        out.emplace_back(std::min(p.id[i], p.id[j]), std::max(p.id[i], p.id[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace granular
