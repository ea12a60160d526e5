#!/usr/bin/env bash
# Pins a long background job to the code of one commit: the commit's tree in
# DIR/src, its engine built in DIR/engine-build and copied to DIR/engine/granular,
# its hash in DIR/COMMIT. Does nothing when DIR/engine/granular exists. Refuses
# (exit 2) when the named paths differ from HEAD, so the job runs committed code.
#
#   scripts/pin_commit.sh DIR LANES NAME PATH...     (NAME: the job, for the message)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$1"; lanes="$2"; name="$3"; shift 3
[ -x "$dir/engine/granular" ] && exit 0
cd "$here"
if ! git diff --quiet HEAD -- "$@"; then
  echo "$name: $* differ from HEAD; commit first, so the job's commit is the code it runs" >&2
  exit 2
fi
commit="$(git rev-parse HEAD)"
rm -rf "$dir/src" "$dir/engine-build"
mkdir -p "$dir/src" "$dir/engine"
git archive "$commit" | tar -x -C "$dir/src"
cmake -S "$dir/src" -B "$dir/engine-build" -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build "$dir/engine-build" -j"$lanes" --target granular >/dev/null
cp "$dir/engine-build/granular" "$dir/engine/granular"
echo "$commit" >"$dir/COMMIT"
