// The particle store: one column per property (structure of arrays). Vector
// columns keep one particle's components together. `id` is stable across
// reorder() and is what output and tests match on.
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/space.hpp"

namespace granular {

template <int Dim>
struct ParticleStore {
  using V = Vec<Dim>;
  using A = Ang<Dim>;

  std::vector<V> x;       // position
  std::vector<V> v;       // velocity
  std::vector<A> w;       // angular velocity
  std::vector<V> f;       // force (contacts only; gravity is added as an acceleration)
  std::vector<A> tq;      // torque
  std::vector<double> d;  // diameter
  std::vector<double> inv_m;
  std::vector<double> inv_i;  // inverse moment of inertia
  std::vector<std::int32_t> species;
  std::vector<std::int64_t> id;
  // Extra per-particle state that some integrators keep (Gear's higher time
  // derivatives). Empty unless an integrator asks for it; permuted with the rest.
  std::vector<std::vector<V>> aux_v;
  std::vector<std::vector<A>> aux_a;

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

  // Permute every column: new[k] = old[perm[k]]. Applied after a cell sort so
  // that particles close in space are close in memory. Called inside an OpenMP
  // parallel region by every thread with its own block [lo, hi): each thread
  // writes only its own block, so the data it integrates next stays in its cache.
  void reorder_in_parallel(const std::vector<std::uint32_t>& perm, std::size_t lo, std::size_t hi) {
    permute(x, scratch_v_, perm, lo, hi);
    permute(v, scratch_v_, perm, lo, hi);
    permute(f, scratch_v_, perm, lo, hi);
    permute(w, scratch_a_, perm, lo, hi);
    permute(tq, scratch_a_, perm, lo, hi);
    permute(d, scratch_d_, perm, lo, hi);
    permute(inv_m, scratch_d_, perm, lo, hi);
    permute(inv_i, scratch_d_, perm, lo, hi);
    permute(species, scratch_s_, perm, lo, hi);
    permute(id, scratch_id_, perm, lo, hi);
    for (auto& col : aux_v) permute(col, scratch_v_, perm, lo, hi);
    for (auto& col : aux_a) permute(col, scratch_a_, perm, lo, hi);
  }

 private:
  template <class T>
  static void permute(std::vector<T>& col, std::vector<T>& scratch, const std::vector<std::uint32_t>& perm,
                      std::size_t lo, std::size_t hi) {
#pragma omp single
    scratch.resize(col.size());
    for (std::size_t k = lo; k < hi; ++k) scratch[k] = col[perm[k]];
#pragma omp barrier
#pragma omp single
    col.swap(scratch);
  }

  std::vector<V> scratch_v_;
  std::vector<A> scratch_a_;
  std::vector<double> scratch_d_;
  std::vector<std::int32_t> scratch_s_;
  std::vector<std::int64_t> scratch_id_;
};

}  // namespace granular
