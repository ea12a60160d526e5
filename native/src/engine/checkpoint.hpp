// A simulation to and from a checkpoint (io/checkpoint_file.hpp).
//
// What makes the continuation bit for bit the uninterrupted run:
// - the particle store in storage order, every column raw: x, v, w, the forces
//   and torques of the last step (the next half kick uses them), d, 1/m, 1/I,
//   species, id, and any integrator columns (Gear's higher derivatives);
// - the neighbour list's reference positions: rebuilding the list from them
//   gives back the list in use, row for row (the cell sort is stable and the
//   store is already in its order), hence the same force summation order;
// - time and step count as the run accumulated them, and the output counters.
// No contact law here keeps history (all tangential forces are viscous), and
// no random numbers are drawn after set-up, so nothing else carries state.
#pragma once
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/column.hpp"
#include "io/checkpoint_file.hpp"

namespace granular {

namespace ckpt_detail {

template <class T, class Alloc>
std::vector<double> flat(const std::vector<T, Alloc>& col) {
  static_assert(sizeof(T) == T::SizeAtCompileTime * sizeof(double), "vector columns must be packed doubles");
  std::vector<double> out(col.size() * T::SizeAtCompileTime);
  if (!col.empty()) std::memcpy(out.data(), col.data(), out.size() * sizeof(double));
  return out;
}

template <class T, class Alloc>
void unflat(const CheckpointData& c, const std::string& name, std::size_t n, std::vector<T, Alloc>& col) {
  const auto it = c.reals.find(name);
  if (it == c.reals.end()) throw std::runtime_error("the checkpoint lacks column " + name);
  if (it->second.size() != n * T::SizeAtCompileTime)
    throw std::runtime_error("checkpoint column " + name + " has the wrong length for this scene");
  col.resize(n);
  if (n) std::memcpy(static_cast<void*>(col.data()), it->second.data(), it->second.size() * sizeof(double));
}

inline const std::vector<double>& reals(const CheckpointData& c, const std::string& name, std::size_t n) {
  const auto it = c.reals.find(name);
  if (it == c.reals.end() || it->second.size() != n)
    throw std::runtime_error("checkpoint column " + name + " is missing or has the wrong length for this scene");
  return it->second;
}

inline const std::vector<std::int64_t>& ints(const CheckpointData& c, const std::string& name, std::size_t n) {
  const auto it = c.ints.find(name);
  if (it == c.ints.end() || it->second.size() != n)
    throw std::runtime_error("checkpoint column " + name + " is missing or has the wrong length for this scene");
  return it->second;
}

}  // namespace ckpt_detail

// The simulation's state into c (the caller fills the run-level fields).
template <class Sim>
void capture(const Sim& sim, CheckpointData& c) {
  using namespace ckpt_detail;
  const auto& p = sim.p;
  c.step = sim.step_count;
  c.time = sim.time;
  c.reals["x"] = flat(p.x);
  c.reals["v"] = flat(p.v);
  c.reals["w"] = flat(p.w);
  c.reals["f"] = flat(p.f);
  c.reals["tq"] = flat(p.tq);
  c.reals["d"].assign(p.d.begin(), p.d.end());
  c.reals["inv_m"].assign(p.inv_m.begin(), p.inv_m.end());
  c.reals["inv_i"].assign(p.inv_i.begin(), p.inv_i.end());
  c.reals["x_ref"] = flat(sim.neighbors().reference_positions());
  c.ints["species"] = std::vector<std::int64_t>(p.species.begin(), p.species.end());
  c.ints["id"].assign(p.id.begin(), p.id.end());
  for (std::size_t k = 0; k < p.aux_v.size(); ++k) c.reals["aux_v" + std::to_string(k)] = flat(p.aux_v[k]);
  for (std::size_t k = 0; k < p.aux_a.size(); ++k) c.reals["aux_a" + std::to_string(k)] = flat(p.aux_a[k]);
}

// Puts c's state into sim's store, time and step count, which must have been
// made from the same scene (the particle count and each column's length are
// checked); returns the positions the saved neighbour list was built from.
template <class Sim>
Column<typename Sim::V> restore_state(Sim& sim, const CheckpointData& c) {
  using namespace ckpt_detail;
  auto& p = sim.p;
  const std::size_t n = p.size();
  unflat(c, "x", n, p.x);
  unflat(c, "v", n, p.v);
  unflat(c, "w", n, p.w);
  unflat(c, "f", n, p.f);
  unflat(c, "tq", n, p.tq);
  const auto into = [](const auto& saved, auto& col) { col.assign(saved.begin(), saved.end()); };
  into(reals(c, "d", n), p.d);
  into(reals(c, "inv_m", n), p.inv_m);
  into(reals(c, "inv_i", n), p.inv_i);
  into(ints(c, "species", n), p.species);
  into(ints(c, "id", n), p.id);
  for (std::size_t k = 0; k < p.aux_v.size(); ++k) unflat(c, "aux_v" + std::to_string(k), n, p.aux_v[k]);
  for (std::size_t k = 0; k < p.aux_a.size(); ++k) unflat(c, "aux_a" + std::to_string(k), n, p.aux_a[k]);
  Column<typename Sim::V> x_ref;
  unflat(c, "x_ref", n, x_ref);
  sim.time = c.time;
  sim.step_count = c.step;
  return x_ref;
}

// Puts c's state into sim (restore_state) and rebuilds its neighbour list
// from the saved reference positions.
template <class Sim>
void restore(Sim& sim, const CheckpointData& c) {
  sim.restore_neighbors(restore_state(sim, c));
}

}  // namespace granular
