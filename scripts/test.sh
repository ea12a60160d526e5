#!/usr/bin/env bash
# Every test: C++ (GoogleTest) and Python (pytest) through CTest, the native
# tests again under AddressSanitizer + UndefinedBehaviorSanitizer and the
# threaded ones under ThreadSanitizer, then the cross-engine quick suite and
# its report in a browser.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each part's wall time, as it ends (where the whole run's time goes).
start=$SECONDS
took() { echo "test.sh: $1 took $((SECONDS - start)) s"; start=$SECONDS; }
bash scripts/setup.sh
took "set-up and build"
cd build
ctest --output-on-failure -j"$(nproc)"
cd ..
took "CTest"
bash scripts/sanitize.sh
took "checking builds and their tests"
# The cross-engine quick suite (docs/tolerances.md): the native engine, LAMMPS
# and YADE on a short drum that forms its bands and on the box below and above
# the big disk's rise threshold; exits non-zero unless every gating comparison
# is equivalent and every engine shows the threshold. Three lanes on two cores:
# a YADE run leaves a quarter of its core idle.
/usr/bin/python3 -m compare validate --suite quick -o build/validate_quick --lanes 3
took "quick suite"
# Its report, opened in headless Chromium: the table and every image render.
/usr/bin/python3 -m compare.browser_check build/validate_quick/report.html \
  --screenshot build/test_output/validate_quick.png
took "browser check"
