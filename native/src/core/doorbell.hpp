// Waiting for a number another thread publishes: spin a little, then sleep
// until the publisher rings.
//
// Within a step the threads meet at numbers they publish (engine/parallel/thread_team.hpp,
// Done), a few microseconds apart when each thread has a core. A waiter spins
// for about as long as libgomp's waiting threads do in this program
// (app/openmp_wait.hpp: GOMP_SPINCOUNT=1000, some 30 microseconds here), then
// sleeps on a futex, giving its core to whatever else the machine has to run.
// Measured on this 2-core host (docs/speed_accuracy.md, "Threads on a shared machine"), two 2-thread
// runs of a 528-particle drum at once (0.6 s each alone):
//   - spinning only: 27-65 s each, since the thread being waited for may be
//     queued behind the spinner on the same core, and each wait then lasts a
//     time slice;
//   - yielding the core after 256 looks: 1.2-2.2 s; but beside two unrelated
//     busy processes a yield hands the slice to them, and 200 000 cache-line
//     round trips between two threads took over 120 s;
//   - sleeping after 1000 looks (this): 2.3-2.6 s in 7 tries, and the round
//     trips beside the busy processes 1.7 s;
//   - sleeping after 200 looks: 1.7-2.1 s, but alone on the cores two threads
//     ran 7 % (drum) and 11 % (box) slower than with 1000, in 4 of 4 paired
//     rounds: the meeting points often wait longer than 200 looks.
// A sleeper is woken by the next ring; publishers pay a fence and a load when
// no one sleeps.
#pragma once
#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <climits>
#include <cstdint>

namespace granular {

class Doorbell {
 public:
  // Looks at the number before sleeping, 29 ns apart (x86 pause, Zen 3).
  static constexpr unsigned kSpinLooks = 1000;

  Doorbell() = default;
  // A copy has no sleepers (copied between steps, when no thread waits).
  Doorbell(const Doorbell&) {}
  Doorbell& operator=(const Doorbell&) { return *this; }

  // After the publishing store: wakes whoever sleeps on this bell. The fence
  // orders the store before the look at the sleepers (and a waiter's count
  // before its look at the number), so that no waiter can miss both.
  void ring() {
    std::atomic_thread_fence(std::memory_order_seq_cst);
    if (sleepers_.load(std::memory_order_relaxed) == 0) return;
    bell_.fetch_add(1, std::memory_order_release);  // a waiter reading the new bell sees the number
    syscall(SYS_futex, &bell_, FUTEX_WAKE_PRIVATE, INT_MAX, nullptr, nullptr, 0);
  }

  // Returns once ready() (an acquire load of the published number) holds.
  template <class Ready>
  void wait_until(Ready&& ready) {
    for (unsigned k = 0; k < kSpinLooks; ++k) {
      if (ready()) return;
      pause();
    }
    sleepers_.fetch_add(1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_seq_cst);
    for (;;) {
      // The bell is read before the number: a ring after this read changes
      // it, and the futex then returns at once instead of sleeping.
      const std::uint32_t b = bell_.load(std::memory_order_acquire);
      if (ready()) break;
      syscall(SYS_futex, &bell_, FUTEX_WAIT_PRIVATE, b, nullptr, nullptr, 0);
    }
    sleepers_.fetch_sub(1, std::memory_order_relaxed);
  }

  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }

 private:
  std::atomic<std::uint32_t> bell_{0};
  std::atomic<std::uint32_t> sleepers_{0};
};

}  // namespace granular
