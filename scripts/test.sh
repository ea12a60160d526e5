#!/usr/bin/env bash
# Every test: C++ (GoogleTest) and Python (pytest), through CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cd build
ctest --output-on-failure -j"$(nproc)"
