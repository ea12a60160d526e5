// How long libgomp's waiting threads spin before they sleep.
//
// Unless told otherwise, libgomp spins a waiting thread 300 000 times (a few
// milliseconds) before it sleeps: at a barrier, at the end of a parallel
// region, and a worker between regions. On a machine running more threads
// than it has cores (two runs at once, a CI running tests side by side) the
// thread being waited for can be queued behind the spinning one on the same
// core, and every wait then lasts a time slice. Two 2-thread runs at once
// (with the step's own waits as in core/doorbell.hpp) of the box at 3 Hz
// (1135 particles, 3 s) took 0.9-57 s each, of a 528-particle drum 1.0-41 s
// (3 tries each);
// with GOMP_SPINCOUNT=1000, 2.3-2.8 s and 2.3-2.6 s in 7 tries each. Alone
// on the cores, a run measured the same either way, within the host's noise
// (docs/speed_accuracy.md, "Threads on a shared machine").
//
// libgomp reads its environment once, when it loads, before main runs; and a
// function in the executable's .preinit_array, which runs earlier, cannot yet
// change the environment (the C library sets it up afterwards). So when the
// environment sets neither GOMP_SPINCOUNT nor OMP_WAIT_POLICY, the program
// sets GOMP_SPINCOUNT and starts itself again (the same process, the same
// arguments). Either variable set by the user is left as it is.
#pragma once
#include <unistd.h>

#include <cstdlib>

namespace granular {

inline constexpr const char* kSpinCount = "1000";

// Called first in main. Returns only when the program goes on in this image:
// the environment already chose, or the restart failed (the run then goes on
// with libgomp's default).
inline void spin_briefly_before_sleeping(char** argv) {
  if (std::getenv("GOMP_SPINCOUNT") != nullptr || std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  if (setenv("GOMP_SPINCOUNT", kSpinCount, 0) != 0) return;
  execv("/proc/self/exe", argv);
}

}  // namespace granular
