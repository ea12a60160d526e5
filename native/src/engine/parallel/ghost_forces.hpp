// Where the threads' pair loops put forces and torques, and the sum that
// brings them into the store in a fixed order.
//
// Thread t owns the particles of its block (NeighborList::block). The rows
// of the block's core (NeighborList::core_end) write their particles' force
// and torque straight into the store, and a contact's share for a particle
// outside the block into the thread's ghost buffer (indexed like the store).
// The block's tail tasks (engine/parallel/tail_tasks.hpp) write every share
// into the task's own buffer. After the step's meeting each thread adds, for
// its block, the other threads' ghost entries in thread order and then every
// task's entries in task order: the sums are bitwise repeatable for a thread
// count, whoever ran the tasks; one thread has no ghosts and no tasks. Only
// the chunks of a buffer its writer touches (NeighborList::touched,
// tail_chunks) are read and zeroed, so little data crosses between cores.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/column.hpp"
#include "core/space.hpp"
#include "neighbor/neighbor_list.hpp"

namespace granular {

// Where a thread's pair loop puts forces and torques: the store for the
// particles of its block [lo, lo + len), its ghost buffer for the others
// (the store itself when one thread owns every particle).
template <int Dim>
struct Sinks {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  V* f;
  A* t;
  V* gf;
  A* gt;
  std::size_t lo, len;
  V& force(std::uint32_t j) const { return (j - lo < len ? f : gf)[j]; }
  A& torque(std::uint32_t j) const { return (j - lo < len ? t : gt)[j]; }
  V& own_force(std::size_t i) const { return f[i]; }
  A& own_torque(std::size_t i) const { return t[i]; }
};

// Where a tail task puts them: its buffer, for every particle
// (NeighborList::tail_offsets).
template <int Dim>
struct TaskSinks {
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  V* f;
  A* t;
  const std::int64_t* off;
  std::int64_t at(std::size_t j) const { return off[j / NeighborList<Dim>::kChunk] + static_cast<std::int64_t>(j); }
  V& force(std::uint32_t j) const { return f[at(j)]; }
  A& torque(std::uint32_t j) const { return t[at(j)]; }
  V& own_force(std::size_t i) const { return f[at(i)]; }
  A& own_torque(std::size_t i) const { return t[at(i)]; }
};

template <int Dim>
class GhostForces {
 public:
  using V = Vec<Dim>;
  using A = Ang<Dim>;
  static constexpr std::size_t kChunk = NeighborList<Dim>::kChunk;

  // The per-thread ghost buffers for nt threads and n particles, sized before
  // a parallel region opens (inside it, sizing them would cost a barrier
  // every step). Each thread zeroes what it writes (zero()).
  void prepare(int nt, std::size_t n) {
    const std::size_t nb = nt > 1 ? static_cast<std::size_t>(nt) : 0;
    if (fbuf_.size() != nb || (nb > 0 && fbuf_[0].size() != n)) {
      fbuf_.assign(nb, Column<V>(n, V::Zero()));
      tbuf_.assign(nb, Column<A>(n, A::Zero()));
    }
  }

  // After a build: the tail tasks' buffers, one entry per particle of the
  // chunks each writes (zeroed by the thread that runs the task).
  void size_tasks(const NeighborList<Dim>& nl) {
    const std::size_t ntasks = static_cast<std::size_t>(nl.tails() * nl.threads());
    task_f_.resize(ntasks);
    task_t_.resize(ntasks);
    for (std::size_t task = 0; task < ntasks; ++task) {
      const std::size_t m = nl.tail_chunks(task).size() * kChunk;
      task_f_[task].resize(m);
      task_t_[task].resize(m);
    }
  }

  // Thread t's sinks for its block [lo, hi) of the store (f, tq).
  Sinks<Dim> sinks(int t, std::size_t lo, std::size_t hi, V* f, A* tq) {
    Sinks<Dim> sk{f, tq, f, tq, lo, hi - lo};
    if (!fbuf_.empty()) {
      sk.gf = fbuf_[static_cast<std::size_t>(t)].data();
      sk.gt = tbuf_[static_cast<std::size_t>(t)].data();
    }
    return sk;
  }

  // A tail task's sinks, its buffer zeroed (by the thread that runs it).
  TaskSinks<Dim> task_sinks(std::size_t task, const NeighborList<Dim>& nl) {
    Column<V>& bf = task_f_[task];
    Column<A>& bt = task_t_[task];
    std::fill(bf.begin(), bf.end(), V::Zero());
    std::fill(bt.begin(), bt.end(), A::Zero());
    return TaskSinks<Dim>{bf.data(), bt.data(), nl.tail_offsets(task)};
  }

  // Zeroes the chunks of thread t's ghost buffer that its rows write.
  void zero(int t, const NeighborList<Dim>& nl) {
    V* gf = fbuf_[static_cast<std::size_t>(t)].data();
    A* gt = tbuf_[static_cast<std::size_t>(t)].data();
    const std::size_t n = fbuf_[static_cast<std::size_t>(t)].size();
    for (const std::uint32_t c : nl.touched_chunks(t)) {
      const std::size_t a = c * kChunk, e = std::min(n, a + kChunk);
      std::fill(gf + a, gf + e, V::Zero());
      std::fill(gt + a, gt + e, A::Zero());
    }
  }

  // Adds to thread t's block [lo, hi) of the store the other threads' ghost
  // entries, in thread order, then the tasks' entries, in task order. Their
  // writers zero them before they next write them, after the next step's
  // gate (engine/parallel/thread_team.hpp), which no thread passes before all
  // have finished this sum.
  void add_into(int t, std::size_t lo, std::size_t hi, const NeighborList<Dim>& nl, V* f, A* tq) const {
    const int nt = static_cast<int>(fbuf_.size());
    const std::size_t ntasks = task_f_.size();
    for (std::size_t i = lo; i < hi;) {
      const std::size_t c = i / kChunk, e = std::min(hi, (c + 1) * kChunk);
      for (int u = 0; u < nt; ++u)
        if (u != t && nl.touched(u, c)) {
          const V* gf = fbuf_[static_cast<std::size_t>(u)].data();
          const A* gt = tbuf_[static_cast<std::size_t>(u)].data();
          for (std::size_t q = i; q < e; ++q) {
            f[q] += gf[q];
            tq[q] += gt[q];
          }
        }
      for (std::size_t task = 0; task < ntasks; ++task)
        if (nl.tail_touched(task, c)) {
          const std::int64_t o = nl.tail_offsets(task)[c];
          const V* bf = task_f_[task].data();
          const A* bt = task_t_[task].data();
          for (std::size_t q = i; q < e; ++q) {
            f[q] += bf[o + static_cast<std::int64_t>(q)];
            tq[q] += bt[o + static_cast<std::int64_t>(q)];
          }
        }
      i = e;
    }
  }

 private:
  std::vector<Column<V>> fbuf_;  // per thread, on two or more
  std::vector<Column<A>> tbuf_;
  std::vector<Column<V>> task_f_;  // per tail task (NeighborList::tail_offsets)
  std::vector<Column<A>> task_t_;
};

}  // namespace granular
