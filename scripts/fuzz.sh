#!/usr/bin/env bash
# Fuzz the scene loader with libFuzzer (clang), under AddressSanitizer and
# UndefinedBehaviorSanitizer (tests/fuzz/README.md).
#   scripts/fuzz.sh [SECONDS=600] [WORKDIR=build-fuzz/work]
# Starts from tests/fuzz/corpus/ plus every scene and bad scene in the tree;
# new inputs go to WORKDIR/corpus, a crashing input to WORKDIR/crash-*. Then
# `scripts/fuzz.sh merge` folds WORKDIR/corpus into tests/fuzz/corpus/ (only
# inputs that add coverage), which tests/native/test_fuzz_corpus.cpp replays.
set -euo pipefail
cd "$(dirname "$0")/.."
work="${2:-build-fuzz/work}"
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPython3_EXECUTABLE=/usr/bin/python3 \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DGRANULAR_SANITIZE=address,undefined \
  -DGRANULAR_FUZZ=ON -DGRANULAR_CUDA=OFF >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target scene_fuzzer
mkdir -p "$work/corpus"
if [ "${1:-}" = merge ]; then
  build-fuzz/scene_fuzzer -merge=1 tests/fuzz/corpus "$work/corpus"
  exit 0
fi
cp -n tests/fuzz/corpus/* scenes/drum/*.toml scenes/box/*.toml tests/bad_scenes/*.toml "$work/corpus/" 2>/dev/null || true
build-fuzz/scene_fuzzer "$work/corpus" -dict=tests/fuzz/scene.dict -max_total_time="${1:-600}" -max_len=4096 \
  -timeout=10 -rss_limit_mb=2048 -artifact_prefix="$work/" -print_final_stats=1
