#!/usr/bin/env bash
# The GPU engine's check on a GPU machine that has none of the project's
# Debian libraries (docs/gpu.md, "Checking on a GPU machine").
#
#   scripts/gpu_check.sh pack [PACK]          on the Debian machine with CUDA:
#       a Release build with the CUDA kernels (build-gpu/), then PACK (default
#       gpu_pack/, ignored by git) holds granular, the GPU tests, and lib/: the
#       shared libraries ldd lists for them and Debian's loader.
#   scripts/gpu_check.sh run [PACK] [OUT]     on the GPU machine, from the
#       repository root (the scenes travel with the working tree): the GPU
#       tests, then the GPU benchmark beside the CPU engine on the machine's
#       cores; logs and JSON in OUT (default gpu_check_out/). About 5 minutes
#       on an H100 with 16 cores.
#
# The programs start through the carried loader
# (lib/ld-linux-x86-64.so.2 --library-path lib PROGRAM), with GOMP_SPINCOUNT
# set so that granular does not start itself again through the system's
# loader (native/src/app/openmp_wait.hpp).
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-}"
pack="${2:-gpu_pack}"

pack() {
  # x86-64-v3 (AVX2, FMA instructions) rather than this machine's -march=native:
  # the GPU machine's processor may be another make.
  cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3 \
    -DGRANULAR_NATIVE_ARCH=OFF -DCMAKE_CXX_FLAGS=-march=x86-64-v3 >/dev/null
  if ! cmake --build build-gpu --target help | grep granular_cuda >/dev/null; then
    echo "gpu_check: CMake found no CUDA (see docs/gpu.md, Building)" >&2; exit 2
  fi
  cmake --build build-gpu -j"$(nproc)" --target granular test_gpu_cuda test_gpu_drum test_gpu_box
  rm -rf "$pack"
  mkdir -p "$pack/lib"
  cp build-gpu/granular build-gpu/tests/native/test_gpu_{cuda,drum,box} "$pack/"
  for exe in "$pack"/granular "$pack"/test_gpu_*; do
    ldd "$exe" | awk '/=> \// { print $3 } /^\t\/lib/ { print $1 }'
  done | sort -u | while read -r lib; do
    cp -L "$lib" "$pack/lib/"
  done
  cp -L /lib64/ld-linux-x86-64.so.2 "$pack/lib/ld-linux-x86-64.so.2"
  # The CUDA driver (libcuda.so.1) is the GPU machine's own, loaded at run
  # time; the C library's parts it may ask for come from here, so that they
  # match the carried libc.
  for lib in libpthread.so.0 libdl.so.2 librt.so.1; do
    cp -L "/lib/x86_64-linux-gnu/$lib" "$pack/lib/"
  done
  du -sh "$pack"
}

run() {
  local out="${3:-gpu_check_out}"
  mkdir -p "$out"
  local root="$PWD"
  export GOMP_SPINCOUNT="${GOMP_SPINCOUNT:-1000}" GRANULAR_SOURCE_DIR="$root"
  # The carried libraries first; then where the driver's libcuda.so.1 may be
  # (--library-path replaces LD_LIBRARY_PATH, so it is appended here).
  local libs="$root/$pack/lib:${LD_LIBRARY_PATH:-}:/usr/local/nvidia/lib64:/usr/local/nvidia/lib"
  local ld=("$root/$pack/lib/ld-linux-x86-64.so.2" --library-path "$libs")
  local g=("${ld[@]}" "$root/$pack/granular")
  local status=0
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv | tee "$out/gpu.txt" || true
  nproc | tee "$out/cores.txt"

  echo "gpu_check: the CUDA build against the host build (test_gpu_cuda)"
  "${ld[@]}" "$root/$pack/test_gpu_cuda" --gtest_output=json:"$out/test_gpu_cuda.json" 2>&1 |
    tee "$out/test_gpu_cuda.log" || status=1
  for t in test_gpu_drum test_gpu_box; do
    echo "gpu_check: the host build against the CPU engine ($t)"
    "${ld[@]}" "$root/$pack/$t" --gtest_output=json:"$out/$t.json" 2>&1 | tee "$out/$t.log" || status=1
  done

  echo "gpu_check: GPU benchmark"
  # #T (62 244 particles), #A (4 664), 32 replicas of #A, and #A's drum
  # lengthened to about 10^3 ... 10^7 particles (36.4 per unit length).
  bench() {  # name, then granular bench's arguments
    local name="$1"; shift
    echo "  $name: $*"
    timeout 120 "${g[@]}" bench "$@" --json >"$out/bench_$name.json" 2>"$out/bench_$name.err" || {
      echo "  $name failed: $(tail -n 3 "$out/bench_$name.err")"; status=1; }
  }
  bench gpu_T scenes/drum/T.toml --device gpu --rotations 0.5 --settle 0.25 --repeat 3
  bench gpu_T_ids scenes/drum/T.toml --device gpu --gpu-memory-order ids --rotations 0.5 --settle 0.25 --repeat 3
  bench gpu_A scenes/drum/A.toml --device gpu --rotations 2 --settle 0.5 --repeat 3
  bench gpu_A_x32 scenes/drum/A.toml --device gpu --replicas 32 --rotations 1 --settle 0.5 --repeat 3
  for len in 27.5 275 2750 27500 275000; do
    bench "gpu_size_L$len" scenes/drum/A.toml --device gpu --set drum.length=$len --rotations 0.05 --settle 0.02 --repeat 2
  done
  bench gpu_size_L27500_ids scenes/drum/A.toml --device gpu --gpu-memory-order ids --set drum.length=27500 \
    --rotations 0.05 --settle 0.02 --repeat 2
  echo "gpu_check: the CPU engine on the machine's cores, beside it"
  bench cpu_T scenes/drum/T.toml --threads 1 "$(nproc)" --rotations 0.1 --settle 0.25 --repeat 3 --ceiling "$(nproc)"
  # the same threads left free to move (the program binds a team that fills the cores)
  export OMP_PROC_BIND=false
  bench cpu_T_free scenes/drum/T.toml --threads "$(nproc)" --rotations 0.1 --settle 0.25 --repeat 3
  unset OMP_PROC_BIND
  bench cpu_A scenes/drum/A.toml --threads 1 "$(nproc)" --rotations 0.5 --settle 0.5 --repeat 3 --ceiling "$(nproc)"
  /usr/bin/env python3 - "$out" <<'EOF' || true
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
for f in sorted(out.glob("bench_*.json")):
    try:
        rows = json.loads(f.read_text())
    except ValueError:
        continue
    for r in rows if isinstance(rows, list) else [rows]:
        print(f"{f.stem[6:]:>18}  particles {r.get('particles', '?'):>9}  threads {r.get('threads', '-'):>3}  "
              f"replicas {r.get('replicas', 1):>3}  order {r.get('memory_order', '-'):>5}  "
              f"placement {r.get('placement', '-'):>5}  particle-steps/s {r.get('particle_steps_per_second', float('nan')):.3g}")
EOF
  if [ "$status" -ne 0 ]; then echo "gpu_check: FAILED"; else echo "gpu_check: passed"; fi
  return "$status"
}

case "$mode" in
  pack) pack ;;
  run) run "$@" ;;
  *) echo "usage: scripts/gpu_check.sh pack [PACK] | run [PACK] [OUT]" >&2; exit 2 ;;
esac
