// The time step, readable top to bottom. The contact law, integrator and walls
// are template parameters: the scene layer picks them once and the per-contact
// loop contains no dispatch.
#pragma once
#include <omp.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "core/box.hpp"
#include "core/particles.hpp"
#include "core/threads.hpp"
#include "engine/timers.hpp"
#include "neighbor/neighbor_list.hpp"

namespace granular {

// Raised when the dynamics blows up; the message says where and why.
class UnstableError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

template <int Dim, class Law, class Integrator, class... Walls>
class Simulation {
 public:
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  static constexpr int kDim = Dim;

  ParticleStore<Dim> p;
  Box<Dim> box;
  Law law;
  Integrator integrator;
  std::tuple<Walls...> walls;
  double skin = 0.4;
  double time = 0.0;
  long step_count = 0;
  PhaseTimers timers;

  // Call once the store, box, law and walls are set: builds the list and the
  // forces at t = 0 that the first half kick needs.
  void init() {
    max_range_ = 0.0;
    double dmax = 0.0;
    for (double d : p.d) dmax = std::max(dmax, d);
    max_range_ = Law::range(dmax, dmax);
    rebuild();
    compute_forces();
  }

  void step() {
    typename Integrator::DriftStats st;
    {
      ScopedPhase ph(timers, Phase::integrate);
      st = first_half_all();
    }
    check_stable(st);
    if (!(st.disp_bound() <= skin)) {
      ScopedPhase ph(timers, Phase::neighbor);
      rebuild();
    }
    compute_forces();
    {
      ScopedPhase ph(timers, Phase::integrate);
#pragma omp parallel
      {
        const auto [lo, hi] = thread_block(p.size(), omp_get_num_threads(), omp_get_thread_num());
        integrator.second_half(p, lo, hi);
      }
    }
    time += integrator.dt;
    ++step_count;
  }

  void rebuild() {
    nl_.build(p, box, max_range_, skin, [](double a, double b) { return Law::range(a, b); });
  }

  // Pair contacts into per-thread buffers, reduced in thread order (so the
  // result is bitwise repeatable for a thread count), then wall contacts per
  // particle. A thread zeroes and a reducer reads only the chunks of a buffer
  // that its owner writes, so little data crosses between cores.
  void compute_forces() {
    const std::size_t n = p.size();
    const int nt = omp_get_max_threads();
    if (nt != nl_.threads()) rebuild();  // the thread count changed since the last build
    if (static_cast<int>(fbuf_.size()) != nt || fbuf_[0].size() != n) {
      fbuf_.assign(nt, std::vector<V>(n));
      tbuf_.assign(nt, std::vector<A>(n));
    }
    constexpr std::size_t kChunk = NeighborList<Dim>::kChunk;
    const std::size_t n_chunks = (n + kChunk - 1) / kChunk;
    auto t_pairs = PhaseTimers::Clock::now();
    PhaseTimers::Clock::time_point t_walls;
#pragma omp parallel num_threads(nt)
    {
      const int t = omp_get_thread_num();
      V* F = fbuf_[t].data();
      A* T = tbuf_[t].data();
      for (std::size_t c = 0; c < n_chunks; ++c)
        if (nl_.touched(t, c))
          for (std::size_t i = c * kChunk, e = std::min(n, i + kChunk); i < e; ++i) {
            F[i].setZero();
            T[i].setZero();
          }
      const auto [lo, hi] = thread_block(n, nt, t);
      const std::uint32_t* col = nl_.col(t);
      for (std::size_t i = lo; i < hi; ++i) {
        const V xi = p.x[i], vi = p.v[i];
        const A wi = p.w[i];
        const double di = p.d[i];
        const int ci = p.species[i];
        V fi = V::Zero();
        A ti = A::Zero();
        for (std::uint32_t k = nl_.begin(i), ke = nl_.end(i); k < ke; ++k) {
          const std::uint32_t j = col[k];
          const V dr = box.min_image(xi - p.x[j]);
          const double r2 = dr.squaredNorm();
          const double rc = Law::range(di, p.d[j]);
          if (r2 >= rc * rc) continue;
          const auto c = law.pair_force(dr, r2, di, p.d[j], vi - p.v[j], wi, p.w[j], ci, p.species[j]);
          fi += c.f;
          ti += c.ti;
          F[j] -= c.f;
          T[j] += c.tj;
        }
        F[i] += fi;
        T[i] += ti;
      }
#pragma omp barrier
      for (std::size_t i = lo; i < hi;) {
        const std::size_t c = i / kChunk, e = std::min(hi, (c + 1) * kChunk);
        for (std::size_t q = i; q < e; ++q) {
          p.f[q].setZero();
          p.tq[q].setZero();
        }
        for (int u = 0; u < nt; ++u)
          if (nl_.touched(u, c))
            for (std::size_t q = i; q < e; ++q) {
              p.f[q] += fbuf_[u][q];
              p.tq[q] += tbuf_[u][q];
            }
        i = e;
      }
#pragma omp barrier
#pragma omp master
      t_walls = PhaseTimers::Clock::now();
      std::apply([&](const auto&... w) { (w.apply(p, law, lo, hi), ...); }, walls);
    }
    const auto t_end = PhaseTimers::Clock::now();
    timers.add(Phase::pairs, t_walls - t_pairs);
    timers.add(Phase::walls, t_end - t_walls);
  }

  const NeighborList<Dim>& neighbors() const { return nl_; }

  // Unstable if any particle moved further in one step than the skin allows
  // (contacts could be missed and Eq. (1) diverges), or if anything is not finite.
  double max_step_move() const { return 0.5 * skin; }

 private:
  typename Integrator::DriftStats first_half_all() {
    const int nt = omp_get_max_threads();
    std::vector<typename Integrator::DriftStats> per(nt);
    const auto& xref = nl_.reference_positions();
#pragma omp parallel num_threads(nt)
    {
      const int t = omp_get_thread_num();
      const auto [lo, hi] = thread_block(p.size(), nt, t);
      per[t] = integrator.first_half(p, box, xref, lo, hi);
    }
    typename Integrator::DriftStats st;
    for (const auto& s : per) {
      if (!(s.max_step2 <= st.max_step2)) st.max_step2 = s.max_step2;
      if (!(s.next_disp2 <= st.next_disp2)) st.push_disp(s.next_disp2);
      if (!(s.max_disp2 <= st.next_disp2)) st.push_disp(s.max_disp2);
    }
    return st;
  }

  void check_stable(const typename Integrator::DriftStats& st) const {
    const double lim = max_step_move();
    if (st.max_step2 <= lim * lim) return;
    // Find the culprit (only on failure).
    std::size_t worst = 0;
    double worst_v = -1.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double s = p.v[i].squaredNorm();
      if (!std::isfinite(s) || !std::isfinite(p.x[i].squaredNorm())) { worst = i; worst_v = s; break; }
      if (s > worst_v) { worst = i; worst_v = s; }
    }
    std::ostringstream os;
    os << "simulation unstable (or time step too large) at step " << step_count + 1 << " (t = " << time + integrator.dt << "): particle id "
       << p.id[worst] << " ";
    if (!std::isfinite(worst_v) || !std::isfinite(p.x[worst].squaredNorm()))
      os << "has a non-finite position or velocity";
    else
      os << "moved " << std::sqrt(worst_v) * integrator.dt << " in one step, more than the neighbour list allows (" << lim
         << " = skin/2); speed " << std::sqrt(worst_v);
    os << ". Reduce integrator.dt or check the contact parameters.";
    throw UnstableError(os.str());
  }

  NeighborList<Dim> nl_;
  double max_range_ = 0.0;
  std::vector<std::vector<V>> fbuf_;
  std::vector<std::vector<A>> tbuf_;
};

}  // namespace granular
