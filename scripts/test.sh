#!/usr/bin/env bash
# Every test: C++ (GoogleTest) and Python (pytest) through CTest, the native
# tests again under AddressSanitizer + UndefinedBehaviorSanitizer and the
# threaded ones under ThreadSanitizer, then the cross-engine quick suite and
# its report in a browser.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cd build
ctest --output-on-failure -j"$(nproc)"
cd ..
bash scripts/sanitize.sh
# The cross-engine quick suite (docs/tolerances.md): the native engine, LAMMPS
# and YADE on a short drum that forms its bands and on the box below and above
# the big disk's rise threshold; exits non-zero unless every gating comparison
# is equivalent and every engine shows the threshold. Three lanes on two cores:
# a YADE run leaves a quarter of its core idle.
/usr/bin/python3 -m compare validate --suite quick -o build/validate_quick --lanes 3
# Its report, opened in headless Chromium: the table and every image render.
/usr/bin/python3 -m compare.browser_check build/validate_quick/report.html \
  --screenshot build/test_output/validate_quick.png
