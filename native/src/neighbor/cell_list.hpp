// Cell list by counting sort (count per cell, exclusive scan, scatter), after
// Cabana's LinkedCellList. Cells are at least `min_cell` wide, so every pair
// closer than min_cell lies in the same or an adjacent cell.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/box.hpp"

namespace granular {

template <int Dim>
class CellList {
 public:
  using V = Vec<Dim>;

  void build(const Box<Dim>& box, const std::vector<V>& x, double min_cell) {
    const V len = box.length();
    // Axis order: the axis with most cells varies slowest, so contiguous index
    // ranges (and the threads that own them) are slabs along the longest axis.
    for (int k = 0; k < Dim; ++k) {
      int n = std::max(1, static_cast<int>(len[k] / min_cell));
      // A periodic axis with 2 cells would visit its neighbour twice.
      if (box.periodic[k] && n < 3) n = 1;
      n_[k] = n;
      width_[k] = len[k] / n;
      order_[k] = k;
    }
    std::sort(order_.begin(), order_.end(), [&](int a, int b) { return n_[a] < n_[b]; });
    stride_[order_[0]] = 1;
    for (int q = 1; q < Dim; ++q) stride_[order_[q]] = stride_[order_[q - 1]] * n_[order_[q - 1]];
    n_cells_ = stride_[order_[Dim - 1]] * n_[order_[Dim - 1]];

    const std::size_t n = x.size();
    cell_of_.resize(n);
    for (std::size_t i = 0; i < n; ++i) cell_of_[i] = cell_index(box, x[i]);
    cell_start_.assign(n_cells_ + 1, 0);
    for (std::size_t i = 0; i < n; ++i) ++cell_start_[cell_of_[i] + 1];
    for (int c = 0; c < n_cells_; ++c) cell_start_[c + 1] += cell_start_[c];
    sorted_.resize(n);
    std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) sorted_[fill[cell_of_[i]]++] = static_cast<std::uint32_t>(i);
  }

  // Particle indices in cell order (a permutation: use it to reorder the store).
  const std::vector<std::uint32_t>& sorted() const { return sorted_; }
  int n_cells() const { return n_cells_; }
  std::uint32_t begin(int c) const { return cell_start_[c]; }
  std::uint32_t end(int c) const { return cell_start_[c + 1]; }
  int cell_of(std::size_t i) const { return cell_of_[i]; }
  void set_identity_order() {
    // After the store was reordered by sorted(), particle k sits at slot k.
    std::vector<int> c(sorted_.size());
    for (std::size_t k = 0; k < sorted_.size(); ++k) c[k] = cell_of_[sorted_[k]];
    cell_of_.swap(c);
    for (std::size_t k = 0; k < sorted_.size(); ++k) sorted_[k] = static_cast<std::uint32_t>(k);
  }

  // Half stencil of cell c: c itself plus the adjacent cells whose offset is
  // lexicographically positive, with periodic wrap. Visiting (c, c') for c' in
  // half_stencil(c) meets every pair of adjacent cells exactly once (periodic
  // axes have >= 3 cells or are collapsed to 1). Returns the count; out[0] = c.
  int half_stencil(int c, std::array<int, 14>& out) const {
    std::array<int, Dim> ci{};
    for (int k = 0; k < Dim; ++k) ci[k] = (c / stride_[k]) % n_[k];
    int count = 0;
    const int total = Dim == 3 ? 27 : 9;
    for (int s = total / 2; s < total; ++s) {  // s = 13 (3D) / 4 (2D) is the zero offset
      int t = s;
      bool ok = true;
      int idx = 0;
      for (int k = 0; k < Dim; ++k) {
        const int off = t % 3 - 1;
        t /= 3;
        if (n_[k] == 1 && off != 0) { ok = false; break; }
        int q = ci[k] + off;
        if (q < 0 || q >= n_[k]) {
          if (!periodic_[k]) { ok = false; break; }
          q = (q + n_[k]) % n_[k];
        }
        idx += q * stride_[k];
      }
      if (ok) out[count++] = idx;
    }
    return count;
  }

  void set_box(const Box<Dim>& box) { periodic_ = box.periodic; }

 private:
  int cell_index(const Box<Dim>& box, const V& p) const {
    int idx = 0;
    for (int k = 0; k < Dim; ++k) {
      int q = static_cast<int>(std::floor((p[k] - box.lo[k]) / width_[k]));
      // Particles a little outside a non-periodic edge (pressed into a wall)
      // belong to the edge cell; a wrapped periodic coordinate is inside anyway.
      q = std::clamp(q, 0, n_[k] - 1);
      idx += q * stride_[k];
    }
    return idx;
  }

  std::array<int, Dim> n_{};
  std::array<int, Dim> stride_{};
  std::array<int, Dim> order_{};
  std::array<bool, Dim> periodic_{};
  V width_ = V::Zero();
  int n_cells_ = 0;
  std::vector<int> cell_of_;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint32_t> sorted_;
};

}  // namespace granular
