// The particle store: one column per property (structure of arrays). Vector
// columns keep one particle's components together. `id` is stable across
// reorder() and is what output and tests match on.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/column.hpp"
#include "core/space.hpp"

namespace granular {

template <int Dim>
struct ParticleStore {
  using V = Vec<Dim>;
  using A = Ang<Dim>;

  Column<V> x;       // position
  Column<V> v;       // velocity
  Column<A> w;       // angular velocity
  Column<V> f;       // force (contacts only; gravity is added as an acceleration)
  Column<A> tq;      // torque
  Column<double> d;  // diameter
  Column<double> inv_m;
  Column<double> inv_i;  // inverse moment of inertia
  Column<std::int32_t> species;
  Column<std::int64_t> id;
  // Extra per-particle state that some integrators keep (Gear's higher time
  // derivatives). Empty unless an integrator asks for it; permuted with the rest.
  std::vector<Column<V>> aux_v;
  std::vector<Column<A>> aux_a;

  std::size_t size() const { return x.size(); }

  void add(const V& pos, const V& vel, const A& omega, double diameter, double mass, double inertia,
           std::int32_t sp) {
    x.push_back(pos);
    v.push_back(vel);
    w.push_back(omega);
    f.push_back(V::Zero());
    tq.push_back(A::Zero());
    d.push_back(diameter);
    inv_m.push_back(1.0 / mass);
    inv_i.push_back(1.0 / inertia);
    species.push_back(sp);
    id.push_back(static_cast<std::int64_t>(id.size()));
  }

  // Rotational degrees of freedom off (a scene's particles.rotation = false):
  // an infinite moment of inertia, so omega stays at zero whatever the torques
  // and every law sees non-rotating grains. Data, not a branch: a scene with
  // rotation pays nothing for the option.
  void freeze_rotation() {
    std::fill(inv_i.begin(), inv_i.end(), 0.0);
    std::fill(w.begin(), w.end(), A::Zero());
  }

  // Size the scratch columns of reorder_in_parallel(); called before the
  // parallel region (inside it, sizing would cost barriers).
  void prepare_reorder() {
    scratch_v_.resize(size());
    scratch_a_.resize(size());
    scratch_d_.resize(size());
    scratch_s_.resize(size());
    scratch_id_.resize(size());
  }

  // Permute every column: new[k] = old[perm[k]]. Applied after a cell sort so
  // that particles close in space are close in memory. Called inside an OpenMP
  // parallel region by every thread with its own block [lo, hi): each thread
  // writes only its own block, so the data it integrates next stays in its
  // cache. The columns go in rounds, one of each type per round into that
  // type's scratch column, which is then swapped in: two barriers a round, as
  // many rounds as the type with most columns has. forces = false leaves f and
  // tq unpermuted, for a caller that recomputes them before reading them.
  void reorder_in_parallel(const std::vector<std::uint32_t>& perm, std::size_t lo, std::size_t hi,
                           bool forces = true) {
    constexpr std::size_t kMax = 8;
    std::array<Column<V>*, kMax> cv{};
    std::array<Column<A>*, kMax> ca{};
    std::size_t nv = 0, na = 0;
    cv[nv++] = &x;
    cv[nv++] = &v;
    ca[na++] = &w;
    if (forces) {
      cv[nv++] = &f;
      ca[na++] = &tq;
    }
    if (nv + aux_v.size() > kMax || na + aux_a.size() > kMax)
      throw std::logic_error("reorder_in_parallel: more auxiliary columns than it holds");
    for (auto& col : aux_v) cv[nv++] = &col;
    for (auto& col : aux_a) ca[na++] = &col;
    const std::array<Column<double>*, 3> cd{&d, &inv_m, &inv_i};
    const std::size_t rounds = std::max({nv, na, cd.size()});
    for (std::size_t r = 0; r < rounds; ++r) {
      if (r < nv) gather(*cv[r], scratch_v_, perm, lo, hi);
      if (r < na) gather(*ca[r], scratch_a_, perm, lo, hi);
      if (r < cd.size()) gather(*cd[r], scratch_d_, perm, lo, hi);
      if (r == 0) {
        gather(species, scratch_s_, perm, lo, hi);
        gather(id, scratch_id_, perm, lo, hi);
      }
#pragma omp barrier
#pragma omp single
      {
        if (r < nv) cv[r]->swap(scratch_v_);
        if (r < na) ca[r]->swap(scratch_a_);
        if (r < cd.size()) cd[r]->swap(scratch_d_);
        if (r == 0) {
          species.swap(scratch_s_);
          id.swap(scratch_id_);
        }
      }  // implicit barrier
    }
  }

 private:
  template <class T>
  static void gather(const Column<T>& col, Column<T>& scratch, const std::vector<std::uint32_t>& perm,
                     std::size_t lo, std::size_t hi) {
    for (std::size_t k = lo; k < hi; ++k) scratch[k] = col[perm[k]];
  }

  Column<V> scratch_v_;
  Column<A> scratch_a_;
  Column<double> scratch_d_;
  Column<std::int32_t> scratch_s_;
  Column<std::int64_t> scratch_id_;
};

}  // namespace granular
