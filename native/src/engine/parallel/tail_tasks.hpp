// Tail tasks: the last rows of each thread's block (NeighborList::kTails),
// each run by whichever thread claims it first in a force evaluation, into a
// buffer of its own (engine/parallel/ghost_forces.hpp). A thread that has
// finished its own block takes the other blocks' tasks, as long as taking
// them pays (engine/steal_choice.hpp).
#pragma once
#include <atomic>
#include <cstddef>
#include <vector>

#include "core/column.hpp"
#include "engine/steal_choice.hpp"

namespace granular {

template <int kTails>
class TailTasks {
 public:
  // A claim per task for nt threads, sized before a parallel region opens.
  void prepare(int nt) {
    const std::size_t ntasks = nt > 1 ? static_cast<std::size_t>(nt) * kTails : 0;
    if (claims_.size() != ntasks) std::vector<Claim>(ntasks).swap(claims_);
    if (taken_.size() != static_cast<std::size_t>(nt)) taken_.assign(static_cast<std::size_t>(nt), Taken{});
  }

  // Thread t (of nt) runs its own block's tail tasks in order, as long as no
  // other thread has taken them, then takes the other blocks' from their ends
  // (the next block first) until it finds one taken: run(u, k) runs task k of
  // block u. A task's rows read other blocks' particles, so this runs once
  // every thread's first stage is done (the gate's verdict, or a region
  // without a gate). gen: the evaluation, larger than any earlier one's.
  template <class Run>
  void run(int t, int nt, long gen, Run&& run) {
    for (int k = 0; k < kTails; ++k)
      if (claim(static_cast<std::size_t>(t * kTails + k), gen)) run(t, k);
    for (int s = 1; s < nt && steal_choice_.steal(); ++s) {
      const int u = (t + s) % nt;
      for (int k = kTails - 1; k >= 0; --k) {
        if (!claim(static_cast<std::size_t>(u * kTails + k), gen)) break;
        run(u, k);
        ++taken_[static_cast<std::size_t>(t)].n;
      }
    }
  }

  // The tasks of other blocks the threads ran since the last call (between
  // regions).
  long collect_taken() {
    long n = 0;
    for (Taken& c : taken_) {
      n += c.n;
      c.n = 0;
    }
    return n;
  }

  // Whether a free thread takes other blocks' tail tasks; changed between
  // regions, by the master thread only.
  StealChoice& steal_choice() { return steal_choice_; }
  const StealChoice& steal_choice() const { return steal_choice_; }

 private:
  // A tail task taken at most once per evaluation: gen is the last
  // evaluation that claimed it. One cache line each.
  struct alignas(kCacheLine) Claim {
    std::atomic<long> gen{0};
    Claim() = default;
    Claim(const Claim& o) : gen(o.gen.load(std::memory_order_relaxed)) {}
    Claim& operator=(const Claim& o) {
      gen.store(o.gen.load(std::memory_order_relaxed), std::memory_order_relaxed);
      return *this;
    }
  };
  bool claim(std::size_t task, long gen) {
    std::atomic<long>& g = claims_[task].gen;
    long old = g.load(std::memory_order_relaxed);
    return old < gen && g.compare_exchange_strong(old, gen, std::memory_order_acq_rel);
  }
  // A thread's count of other blocks' tasks it ran, on a line of its own.
  struct alignas(kCacheLine) Taken {
    long n = 0;
  };

  std::vector<Claim> claims_;  // per tail task
  std::vector<Taken> taken_;   // per thread
  StealChoice steal_choice_;
};

}  // namespace granular
