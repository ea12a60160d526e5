#!/usr/bin/env bash
# Checking builds, with clang (scripts/setup.sh installs it):
#  1. AddressSanitizer + UndefinedBehaviorSanitizer: every native test, which
#     includes the replay of the scene fuzzer's corpus (tests/fuzz/corpus/).
#  2. ThreadSanitizer on the OpenMP force loop: the multi-threaded tests, with
#     LLVM's OpenMP runtime and its TSan tool (archer), so that the runtime's own
#     synchronisation is understood.
# Any report fails the script (-fno-sanitize-recover, halt_on_error).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs="$(nproc)"
# -O1: the optimisation level the sanitizers' documentation recommends; with
# line tables only (CMakeLists.txt) the engine's templates compile a quarter
# faster than at -O2 with full debug information (engine/box.cpp: 66 against
# 88 CPU-seconds), and the native tests take about 1.5 minutes on two cores.
common=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -DNDEBUG"
  -DPython3_EXECUTABLE=/usr/bin/python3 -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DGRANULAR_CUDA=OFF)
# GRANULAR_CUDA=OFF: nvcc's objects would not be instrumented; the GPU kernels
# are checked here through their host build (native/src/gpu/drum_host.cpp).

# A failed build stops the script (a test that is not built is not run, and
# would not be missed); the build's warnings are shown once each.
build() {
  local dir="$1"; shift
  if ! cmake --build "$dir" -j"$jobs" "$@" >"$dir/build.log" 2>&1; then
    grep -E "error|Error" "$dir/build.log" | head -n 40
    echo "sanitize: the build in $dir failed (its log: $dir/build.log)" >&2
    exit 1
  fi
  grep -E "warning:" "$dir/build.log" | sort -u || true
}

echo "sanitize: AddressSanitizer + UndefinedBehaviorSanitizer build (build-asan)"
cmake -S . -B build-asan "${common[@]}" -DGRANULAR_SANITIZE=address,undefined >/dev/null
build build-asan
# Energy.ConservedWithoutDissipation is left out: 10^6 steps of the same pair
# and wall code the other tests run, ten minutes under the sanitizers.
(cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --output-on-failure -j"$jobs" -E '^Energy\.ConservedWithoutDissipation$')

echo "sanitize: ThreadSanitizer build (build-tsan)"
cmake -S . -B build-tsan "${common[@]}" -DGRANULAR_SANITIZE=thread >/dev/null
tsan_tests=(test_determinism test_checkpoint test_neighbors test_two_d)
build build-tsan --target "${tsan_tests[@]}"
archer="$(ls /usr/lib/llvm-*/lib/libarcher.so | tail -n 1)"
for t in "${tsan_tests[@]}"; do
  echo "sanitize: $t under ThreadSanitizer (2 threads)"
  (cd build-tsan && OMP_NUM_THREADS=2 OMP_TOOL_LIBRARIES="$archer" \
    TSAN_OPTIONS="halt_on_error=1 ignore_noninstrumented_modules=1 second_deadlock_stack=1" \
    GRANULAR_SOURCE_DIR="$PWD/.." "tests/native/$t")
done
echo "sanitize: clean"
