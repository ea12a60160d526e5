#!/usr/bin/env bash
# The full cross-engine suite (docs/tolerances.md, "The full suite") as a
# restartable background job: every engine, 48 drum seeds, eight box packings
# a frequency and the box_threshold runs (about 13.5 CPU-hours on this
# machine, YADE 7 of them), then the suite's planted errors (--mutants all,
# about 5 more).
#
#   scripts/validate_full.sh [DIR] [LANES]     start, or resume after any interruption
#
# DIR (default /var/lib/granular/validate_full) holds the code of the commit
# the suite started from (DIR/COMMIT, DIR/src, DIR/engine) and the suite's
# directory DIR/out (runs/ is the cache: a rerun reuses every finished run, so
# an interrupted suite resumes where it stopped; report.{json,html} and
# report_mutants.{json,html} at the end). It runs at nice 19, so that it takes only what else the machine leaves.
# `scripts/campaign_store.sh save validate_full` keeps each finished run's
# observables (its metadata, DIR/out/runs/*.json) in the repository
# (campaign/validate_full/); where the default DIR is missing (a new machine),
# the suite continues from them, with the code of their commit, and runs only
# what they lack.
# The body is one block, read whole before it runs: editing this file while
# the job runs (it runs from the working tree) cannot change what it does.
{
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$(realpath -m "${1:-/var/lib/granular/validate_full}")"
lanes="${2:-2}"
[ "$dir" = /var/lib/granular/validate_full ] && "$here/scripts/campaign_store.sh" restore validate_full "$dir"
mkdir -p "$dir/out"
"$here/scripts/pin_commit.sh" "$dir" "$lanes" validate_full native scenes compare lammps_cases yade_cases CMakeLists.txt
cd "$dir/src"
export GRANULAR_BIN="$dir/engine/granular"
# The suite's exit status says whether it passed; the mutants run either way.
nice -n 19 /usr/bin/python3 -m compare validate --suite full -o "$dir/out" --lanes "$lanes" || true
exec nice -n 19 /usr/bin/python3 -m compare validate --suite full -o "$dir/out" --lanes "$lanes" --mutants all
exit
}
