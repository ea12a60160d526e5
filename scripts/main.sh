#!/usr/bin/env bash
# The main job on the default scenes: a 60-rotation run of drum #A
# (Rapaport 2002, Table I) and its quick-look space-time plot, in ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mkdir -p out
./build/granular run scenes/drum/A.toml --set run.rotations=60 -o out/A.h5 --force
/usr/bin/python3 -m compare quicklook out/A.h5 -o out/A_spacetime.png
