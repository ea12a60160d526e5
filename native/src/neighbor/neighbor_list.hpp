// Half Verlet list in CSR form (row_start / col), after ExaMiniMD's NeighListCSR.
// Pair (i, j) with j > i is listed if |r_ij| < range(d_i, d_j) + skin. The list
// stays valid until some particle has moved more than skin/2 since the build.
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

  // Sorts the store by cell (reorder), then lists pairs. RangeFn(d_i, d_j) is
  // the contact law's interaction range; a template, so it inlines.
  template <class RangeFn>
  void build(ParticleStore<Dim>& p, const Box<Dim>& box, double max_range, double skin, RangeFn range) {
    skin_ = skin;
    cells_.set_box(box);
    cells_.build(box, p.x, max_range + skin);
    p.reorder(cells_.sorted());
    cells_.set_identity_order();

    const std::size_t n = p.size();
    row_start_.assign(n + 1, 0);
    const int nt = omp_get_max_threads();
    std::vector<std::vector<std::uint32_t>> local(nt);
    std::vector<std::size_t> first(nt + 1, 0), last(nt, 0);
#pragma omp parallel
    {
      const int t = omp_get_thread_num();
      auto& out = local[t];
      out.clear();
      std::array<int, 14> st{};
      const auto [lo, hi] = thread_block(n, nt, t);
      for (std::size_t i = lo; i < hi; ++i) {
        const int ns = cells_.half_stencil(cells_.cell_of(i), st);
        const V xi = p.x[i];
        const double di = p.d[i];
        for (int s = 0; s < ns; ++s) {
          // Own cell: only j > i; forward cells: all of them.
          const std::uint32_t b = s == 0 ? static_cast<std::uint32_t>(i + 1) : cells_.begin(st[s]);
          const std::uint32_t e = cells_.end(st[s]);
          for (std::uint32_t j = b; j < e; ++j) {
            const double rc = range(di, p.d[j]) + skin;
            if (box.min_image(xi - p.x[j]).squaredNorm() < rc * rc) out.push_back(j);
          }
        }
        row_start_[i + 1] = out.size();  // local count so far; fixed below
      }
    }
    // Rows of thread t are the contiguous block thread_block(t), so
    // concatenating in thread order gives a deterministic CSR.
    col_.clear();
    for (int t = 0; t < nt; ++t) {
      const std::size_t base = col_.size();
      const auto [lo, hi] = thread_block(n, nt, t);
      for (std::size_t i = lo; i < hi; ++i) row_start_[i + 1] += base;
      col_.insert(col_.end(), local[t].begin(), local[t].end());
    }
    row_start_[0] = 0;
    x_ref_ = p.x;
    ++builds_;
  }

  std::size_t begin(std::size_t i) const { return row_start_[i]; }
  std::size_t end(std::size_t i) const { return row_start_[i + 1]; }
  std::uint32_t operator[](std::size_t k) const { return col_[k]; }
  std::size_t n_pairs() const { return col_.size(); }
  double skin() const { return skin_; }
  long builds() const { return builds_; }
  const std::vector<V>& reference_positions() const { return x_ref_; }

  // Pairs as (id_i, id_j) with id_i < id_j, sorted: for comparison with the oracle.
  std::vector<std::pair<std::int64_t, std::int64_t>> pairs_by_id(const ParticleStore<Dim>& p) const {
    std::vector<std::pair<std::int64_t, std::int64_t>> out;
    for (std::size_t i = 0; i + 1 < row_start_.size(); ++i)
      for (std::size_t k = begin(i); k < end(i); ++k) {
        auto a = p.id[i], b = p.id[col_[k]];
        out.emplace_back(std::min(a, b), std::max(a, b));
      }
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  CellList<Dim> cells_;
  std::vector<std::size_t> row_start_;
  std::vector<std::uint32_t> col_;
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
