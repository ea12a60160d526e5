// The particle store: one column per property (structure of arrays). Vector
// columns keep one particle's components together. `id` is stable across
// reorder() and is what output and tests match on.
#pragma once
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

  // Permute every column: new[k] = old[perm[k]]. Applied after a cell sort so that
  // particles close in space are close in memory.
  void reorder(const std::vector<std::uint32_t>& perm) {
    permute(x, perm);
    permute(v, perm);
    permute(w, perm);
    permute(f, perm);
    permute(tq, perm);
    permute(d, perm);
    permute(inv_m, perm);
    permute(inv_i, perm);
    permute(species, perm);
    permute(id, perm);
  }

 private:
  template <class T>
  static void permute(std::vector<T>& col, const std::vector<std::uint32_t>& perm) {
    std::vector<T> out(col.size());
    for (std::size_t k = 0; k < perm.size(); ++k) out[k] = col[perm[k]];
    col.swap(out);
  }
};

}  // namespace granular
