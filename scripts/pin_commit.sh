#!/usr/bin/env bash
# Pins a long background job to the code of one commit: the commit's tree in
# DIR/src, its engine built in DIR/engine-build and copied to DIR/engine/granular,
# its hash in DIR/COMMIT. Does nothing when DIR/engine/granular exists. The
# commit is DIR/COMMIT where the job's directory already names one (a job
# restored by scripts/campaign_store.sh), otherwise HEAD, which it refuses
# (exit 2) when the named paths differ from it, so the job runs committed code.
#
#   scripts/pin_commit.sh DIR LANES NAME PATH...     (NAME: the job, for the message)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$1"; lanes="$2"; name="$3"; shift 3
[ -x "$dir/engine/granular" ] && exit 0
cd "$here"
if [ -s "$dir/COMMIT" ]; then
  commit="$(cat "$dir/COMMIT")"
  git cat-file -e "$commit^{commit}" 2>/dev/null ||
    { echo "$name: $dir/COMMIT names $commit, which this repository does not have" >&2; exit 2; }
else
  if ! git diff --quiet HEAD -- "$@"; then
    echo "$name: $* differ from HEAD; commit first, so the job's commit is the code it runs" >&2
    exit 2
  fi
  commit="$(git rev-parse HEAD)"
fi
rm -rf "$dir/src" "$dir/engine-build"
mkdir -p "$dir/src" "$dir/engine"
git archive "$commit" | tar -x -C "$dir/src"
cmake -S "$dir/src" -B "$dir/engine-build" -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build "$dir/engine-build" -j"$lanes" --target granular >/dev/null
cp "$dir/engine-build/granular" "$dir/engine/granular"
echo "$commit" >"$dir/COMMIT"
