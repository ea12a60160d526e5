// What the GPU path's two steppers (gpu/drum_kernels.hpp,
// gpu/box_kernels.hpp) share, one source for both builds (gpu/exec.hpp): the
// particles of one or several replicas in device memory (the replicas'
// particles one after another, vector columns by component,
// x[a * n + i]), their upload from the models and download into a store, the
// neighbour list (gpu/neighbor_kernels.hpp) with its reference positions, and
// the displacement test after a step's first stage that decides, replica by
// replica, whether the list is rebuilt (Simulation's rule: a particle moved
// more than skin/2 since the build) or the step stops (a move beyond
// max_step_move, or one that is not finite: StepUnstable).
//
// Particles are held in slots, in the models' order at the start and, with
// reordering on (the models' `reorder`, the default), moved at each list
// build to the order of their cells along the list's space-filling curve
// (gpu/neighbor_kernels.hpp), so that neighbours lie near each other in
// memory. The ids (the models' order) go with them; download and
// reference_positions return the models' order, and the results are the same
// bits either way.
//
// A model (DrumModel, BoxModel) gives p, x_ref, time, step_count, dt,
// gravity, skin, lo, hi and max_step_move; the scene's stepper adds its walls,
// its integrator's columns and its kernels.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "core/particles.hpp"
#include "gpu/exec.hpp"
#include "gpu/neighbor_kernels.hpp"
#include "gpu/stepper.hpp"

namespace granular::gpu {
inline namespace GRANULAR_EXEC_NS {

// Slot k of out takes slot from[k] of in, component by component.
template <class T>
struct Gather {
  const T* in;
  T* out;
  const std::uint32_t* from;
  unsigned n;
  int components;
  GRANULAR_HD void operator()(unsigned k) const {
    for (int a = 0; a < components; ++a) out[a * n + k] = in[a * n + from[k]];
  }
};
// in's components copied to out, slot by slot.
template <class T>
struct Copy {
  const T* in;
  T* out;
  unsigned n;
  int components;
  GRANULAR_HD void operator()(unsigned k) const {
    for (int a = 0; a < components; ++a) out[a * n + k] = in[a * n + k];
  }
};
// Slot k now holds the k-th sorted id.
struct TakeIds {
  const std::uint32_t* sorted;
  std::uint32_t* id;
  std::uint32_t* slot_of;
  GRANULAR_HD void operator()(unsigned k) const {
    id[k] = sorted[k];
    slot_of[sorted[k]] = k;
  }
};

template <int Dim>
class KernelStepper : public Stepper<Dim> {
 public:
  void download(ParticleStore<Dim>& p, int r) const override {
    const unsigned off = offset(r), len = offsets_[r + 1] - off;
    if (p.size() != len) throw std::invalid_argument(who_ + ": download into a store of another size");
    const auto slot = slot_of_.download();
    download_column(x_, off, slot, p.x);
    download_column(v_, off, slot, p.v);
    download_column(w_, off, slot, p.w);
    download_column(f_, off, slot, p.f);
    download_column(t_, off, slot, p.tq);
  }

  Column<Vec<Dim>> reference_positions(int r) const override {
    const unsigned off = offset(r);
    Column<Vec<Dim>> out(offsets_[r + 1] - off);
    download_column(x_ref_, off, slot_of_.download(), out);
    return out;
  }

  std::vector<std::uint32_t> memory_order() const override { return id_.download(); }

  int replicas() const override { return static_cast<int>(k_); }
  double time() const override { return time_; }
  long step_count() const override { return steps_; }
  long builds() const override { return list_.builds(); }
  const char* backend() const override { return kBackend; }

 protected:
  // The replicas' particles uploaded, and their reference positions where
  // the models resume (all or none: then the list is built from them, row for
  // row the list in use); who: the stepper's name in errors.
  template <class Model>
  KernelStepper(const std::string& who, const std::vector<const Model*>& ms)
      : who_(who), time_(ms.front()->time), steps_(ms.front()->step_count) {
    const Model& m = *ms.front();
    k_ = static_cast<unsigned>(ms.size());
    std::size_t total = 0;
    offsets_.push_back(0);
    for (const Model* r : ms) {
      if (r->time != m.time || r->step_count != m.step_count || r->p.size() == 0)
        throw std::invalid_argument(who_ + ": replicas must start at the same step, each with particles");
      total += r->p.size();
      if (total >= std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument(who_ + ": too many particles for 32-bit indices");
      offsets_.push_back(static_cast<std::uint32_t>(total));
    }
    n_ = static_cast<unsigned>(total);
    reorder_ = m.reorder;
    dt_ = m.dt;
    skin_ = m.skin;
    step_lim2_ = std::numeric_limits<double>::infinity();
    for (const Model* r : ms) step_lim2_ = std::min(step_lim2_, r->max_step_move * r->max_step_move);
    for (int a = 0; a < Dim; ++a) g_[a] = m.gravity[a];
    for (const Model* r : ms) {
      double d_max = 0.0;
      for (double d : r->p.d) d_max = std::max(d_max, d);
      d_max_.push_back(d_max);
    }
    upload_column(columns(ms, &ParticleStore<Dim>::x), x_);
    upload_column(columns(ms, &ParticleStore<Dim>::v), v_);
    upload_column(columns(ms, &ParticleStore<Dim>::w), w_);
    upload_column(columns(ms, &ParticleStore<Dim>::f), f_);
    upload_column(columns(ms, &ParticleStore<Dim>::tq), t_);
    upload_column(columns(ms, &ParticleStore<Dim>::d), d_);
    upload_column(columns(ms, &ParticleStore<Dim>::inv_m), inv_m_);
    upload_column(columns(ms, &ParticleStore<Dim>::inv_i), inv_i_);
    upload_column(columns(ms, &ParticleStore<Dim>::species), species_);
    std::vector<std::uint32_t> rep(n_);
    for (unsigned r = 0; r < k_; ++r)
      for (std::uint32_t i = offsets_[r]; i < offsets_[r + 1]; ++i) rep[i] = r;
    replica_.upload(rep);
    offsets_dev_.upload(offsets_);
    std::vector<std::uint32_t> ids(n_);
    for (unsigned i = 0; i < n_; ++i) ids[i] = i;
    id_.upload(ids);
    slot_of_.upload(ids);
    disp2_.resize(n_);
    resumed_ = !m.x_ref.empty();
    renew_host_.assign(k_, resumed_ ? 0u : 1u);
    if (resumed_) {
      for (const Model* r : ms)
        if (r->x_ref.size() != r->p.size())
          throw std::invalid_argument(who_ + ": the list's reference positions are not one per particle");
      std::vector<const Column<Vec<Dim>>*> refs;
      for (const Model* r : ms) refs.push_back(&r->x_ref);
      upload_column(refs, x_ref_);
    } else {
      x_ref_.resize(Dim * static_cast<std::size_t>(n_));
    }
    moved_with_particles(x_, Dim);
    moved_with_particles(v_, Dim);
    moved_with_particles(w_, kAngDim<Dim>);
    moved_with_particles(f_, Dim);
    moved_with_particles(t_, kAngDim<Dim>);
    moved_with_particles(d_, 1);
    moved_with_particles(inv_m_, 1);
    moved_with_particles(inv_i_, 1);
    moved_with_particles(x_ref_, Dim);
  }

  // A per-particle array (`components` columns of n_ values, component-major)
  // that reordering moves with the particles; the scene's stepper adds its
  // own (the box's anchors and Gear's derivatives). An empty array is left
  // alone.
  void moved_with_particles(DeviceArray<double>& a, int components) {
    if (components > kMostComponents) throw std::logic_error(who_ + ": a per-particle array of too many components");
    moved_.push_back({&a, components});
  }

  // The list's cells over the domain [lo, hi), each replica's sized for its
  // widest particle (as a stepper of that replica alone sizes them, so that
  // its list's rows are in the same order), and rows of `cap` columns to
  // start with.
  template <class Law>
  void reserve_list(const std::array<double, Dim>& lo, const std::array<double, Dim>& hi,
                    const std::array<bool, Dim>& periodic, unsigned cap) {
    std::vector<CellGrid<Dim>> grids;
    for (unsigned r = 0; r < k_; ++r) {
      const auto c = cell_counts(lo, hi, periodic, Law::range(d_max_[r], d_max_[r]) + skin_);
      CellGrid<Dim> grid{};
      for (int a = 0; a < Dim; ++a) {
        grid.n[a] = c[a];
        grid.periodic[a] = periodic[a];
        grid.lo[a] = lo[a];
        grid.width[a] = (hi[a] - lo[a]) / c[a];
      }
      grids.push_back(grid);
    }
    list_.reserve(grids, n_, cap, who_);
  }

  // The list built for the replicas marked in renew_host_, the particles
  // moved to the sorted order first where reordering is on.
  template <class Law, class Domain, class Filter>
  void build(const Domain& domain, const Filter& filter) {
    renew_.upload(renew_host_);
    list_.sort(positions(), replica_.data(), renew_.data(), id_.data(), scratch_);
    if (reorder_) move_to_sorted_order();
    list_.template list<Law>(positions(), replica_.data(), slot_of_.data(), domain, filter, skin_, scratch_);
  }

  // After a step's first stage, from each particle's squared displacement
  // since its list's build (disp2_, +infinity where the step's move is beyond
  // max_step_move or not finite): StepUnstable for the first replica with
  // such a move; else the replicas whose list is rebuilt (a move beyond
  // skin/2) marked in renew_host_, and whether there is one.
  bool must_rebuild() {
    const double lim2 = 0.25 * skin_ * skin_;  // (skin/2)^2
    segment_max(disp2_.data(), offsets_, offsets_dev_.data(), k_, moved2_, max_d_, scratch_);
    bool any = false;
    for (unsigned r = 0; r < k_; ++r) {
      if (!(moved2_[r] <= std::numeric_limits<double>::max())) {
        synchronize();
        throw StepUnstable(static_cast<int>(r));
      }
      renew_host_[r] = moved2_[r] > lim2;
      any = any || renew_host_[r];
    }
    return any;
  }

  // Every particle moved to its place in the list's sorted order: slot k
  // takes the particle of the k-th sorted id, with every array registered by
  // moved_with_particles and the species, each array in place (its address
  // does not change, so the kernels' pointers stay valid); the ids and slots
  // follow. The replicas keep their ranges of slots (their cells' keys are in
  // replica order).
  void move_to_sorted_order() {
    const std::uint32_t* sorted = list_.sorted_ids();
    from_.resize(n_);
    for_each(n_, SlotsOf{sorted, slot_of_.data(), from_.data()});
    spare_.resize(kMostComponents * static_cast<std::size_t>(n_));
    for (const Moved& m : moved_) {
      if (m.a->size() == 0) continue;
      for_each(n_, Gather<double>{m.a->data(), spare_.data(), from_.data(), n_, m.components});
      for_each(n_, Copy<double>{spare_.data(), m.a->data(), n_, m.components});
    }
    spare_species_.resize(n_);
    for_each(n_, Gather<std::int32_t>{species_.data(), spare_species_.data(), from_.data(), n_, 1});
    for_each(n_, Copy<std::int32_t>{spare_species_.data(), species_.data(), n_, 1});
    for_each(n_, TakeIds{sorted, id_.data(), slot_of_.data()});
  }

  // health_ sized for a kernel's per-particle worst overlaps.
  double* health() {
    health_.resize(n_);
    return health_.data();
  }
  // Per replica, the largest of health_.
  std::vector<double> worst_of_health() {
    std::vector<double> out;
    segment_max(health_.data(), offsets_, offsets_dev_.data(), k_, out, max_d_, scratch_);
    return out;
  }

  ListPositions positions() { return ListPositions{x_.data(), x_ref_.data(), d_.data(), n_}; }
  ListRows rows() const { return list_.rows(); }

  // Replica r's first particle; std::invalid_argument for a replica the
  // stepper does not hold.
  unsigned offset(int r) const {
    if (r < 0 || static_cast<unsigned>(r) >= k_)
      throw std::invalid_argument(who_ + ": no replica " + std::to_string(r) + " in this stepper");
    return offsets_[r];
  }

  // Each replica's column col of its store.
  template <class Model, class E>
  static std::vector<const Column<E>*> columns(const std::vector<const Model*>& ms,
                                               Column<E> ParticleStore<Dim>::*col) {
    std::vector<const Column<E>*> out;
    for (const Model* m : ms) out.push_back(&(m->p.*col));
    return out;
  }
  // The replicas' columns (cols[r]: replica r's) into one component-major
  // array: vector columns by component, scalars as they are.
  template <class E, class T>
  void upload_column(const std::vector<const Column<E>*>& cols, DeviceArray<T>& out) const {
    std::vector<T> h(static_cast<std::size_t>(components<E>()) * n_);
    for (unsigned r = 0; r < k_; ++r) {
      const Column<E>& col = *cols[r];
      for (std::size_t i = 0; i < col.size(); ++i) {
        if constexpr (std::is_arithmetic_v<E>) {
          h[offsets_[r] + i] = static_cast<T>(col[i]);
        } else {
          for (int a = 0; a < components<E>(); ++a) h[a * n_ + offsets_[r] + i] = col[i][a];
        }
      }
    }
    out.upload(h);
  }
  // The component-major array's particles [off, off + col.size()) into col.
  // The component-major array's particles of ids [off, off + col.size())
  // into col, in id order, wherever they are held (slot: slot_of_, downloaded).
  template <class E>
  void download_column(const DeviceArray<double>& in, unsigned off, const std::vector<std::uint32_t>& slot,
                       Column<E>& col) const {
    const auto h = in.download();
    for (std::size_t i = 0; i < col.size(); ++i)
      for (int a = 0; a < components<E>(); ++a) col[i][a] = h[static_cast<std::size_t>(a) * n_ + slot[off + i]];
  }
  template <class E>
  static constexpr int components() {
    if constexpr (std::is_arithmetic_v<E>)
      return 1;
    else
      return E::RowsAtCompileTime;
  }

  std::string who_;
  unsigned n_ = 0, k_ = 1;
  std::vector<std::uint32_t> offsets_;     // replica r: particles [offsets_[r], offsets_[r + 1])
  std::vector<std::uint32_t> renew_host_;  // per replica: its reference positions are renewed at the next build
  std::vector<double> moved2_;             // per replica: the step's largest squared displacement
  bool resumed_ = false;                   // the list is built from the models' reference positions
  double time_;
  long steps_;
  double dt_ = 0.0, skin_ = 0.0, step_lim2_ = 0.0;
  std::vector<double> d_max_;  // per replica: its widest particle's diameter
  double g_[Dim] = {};
  DeviceArray<double> x_, v_, w_, f_, t_, d_, inv_m_, inv_i_, x_ref_, disp2_, max_d_, health_;
  DeviceArray<std::int32_t> species_;
  DeviceArray<std::uint32_t> replica_, renew_, offsets_dev_;
  DeviceArray<std::uint32_t> id_, slot_of_;  // each slot's particle, each particle's slot
  NeighborList<Dim> list_;
  Scratch scratch_;

 private:
  struct Moved {
    DeviceArray<double>* a;
    int components;
  };
  static constexpr int kMostComponents = 3;
  bool reorder_ = true;
  std::vector<Moved> moved_;
  DeviceArray<std::uint32_t> from_;
  DeviceArray<double> spare_;
  DeviceArray<std::int32_t> spare_species_;
};

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
