// The native tests' main: the OpenMP threads wait as the granular program's
// do (app/openmp_wait.hpp: a short spin, then sleep), whether a test runs
// under ctest or by hand. With libgomp's default spin, tests side by side on
// more threads than cores (ctest -j2 with 2-thread tests) waited out time
// slices: Energy.ConservedWithoutDissipation took 158-284 s beside the
// checkpoint tests, against 7 s alone.
#include <gtest/gtest.h>

#include "app/openmp_wait.hpp"

int main(int argc, char** argv) {
  granular::spin_briefly_before_sleeping(argv);  // may start the test program again
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
