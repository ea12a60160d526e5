#!/usr/bin/env bash
# The full-length Table I campaign: all 24 runs of Rapaport (2002), Table I, at
# the paper's rotation counts, from the shipped scenes at their default steps
# (docs/table1.md), one run per core, restartable.
#
#   scripts/table1_campaign.sh [DIR] [LANES]      start, or resume after any interruption
#   scripts/table1_campaign.sh --status [DIR]     how far each run has got
#   scripts/campaign_store.sh save table1         keep its state in the repository (campaign/table1/)
#
# DIR (default /var/lib/granular/table1) holds everything: the engine and scenes
# of the commit the campaign started from (DIR/COMMIT, DIR/src, DIR/engine), the
# job list and the runs (DIR/runs/X.h5, X.log, X.h5.ckpt, X.h5.done). Rebuilding
# or changing the working tree does not disturb a campaign; a new commit's
# campaign needs a new DIR. Where the default DIR is missing (a new machine),
# the campaign continues from the state last saved in campaign/table1/
# (scripts/campaign_store.sh), with the engine rebuilt from its commit.
#
# First, the step's check: #A's first 1000 rotations at the paper's step 0.005
# and at the default 0.01, six seeds each (DIR/runs/step/), which decides
# whether the default step gives the same long-run observables (docs/table1.md,
# "The step"). Then the Table I runs in order of cost, the 19 smaller first;
# each checkpoints every 5 minutes and resumes from its checkpoint
# (scripts/campaign.sh). Output at the paper's cadence and small enough to keep
# in the repository: ten snapshots a run, and the axial profile every rotation
# (every k-th rotation, k = rotations/5000 rounded, for runs longer than 7500);
# #J and #K also the last 10 configurations, 5 rotations apart (Fig. 9).
# The body is one block, read whole before it runs: editing this file while
# the job runs (it runs from the working tree) cannot change what it does.
{
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
status=0
if [ "${1:-}" = "--status" ]; then status=1; shift; fi
dir="$(realpath -m "${1:-/var/lib/granular/table1}")"
lanes="${2:-2}"

if ((status)); then
  [ -e "$dir/COMMIT" ] || { echo "no campaign in $dir" >&2; exit 2; }
  echo "campaign in $dir, commit $(cat "$dir/COMMIT")"
  cd "$here"
  exec /usr/bin/python3 -m compare campaign-status "$dir"
fi

[ "$dir" = /var/lib/granular/table1 ] && "$here/scripts/campaign_store.sh" restore table1 "$dir"
mkdir -p "$dir/runs"
"$here/scripts/pin_commit.sh" "$dir" "$lanes" table1_campaign native scenes CMakeLists.txt

# The step's check first, then one job per Table I run, cheapest first
# (particle-steps at the default step).
jobs="$dir/jobs.txt"
if [ ! -e "$jobs" ]; then
  for seed in 1 2 3 4 5 6; do for dt in 0.005 0.01; do
    echo "$dir/runs/step/A_dt${dt}_s$seed.h5 $dir/src/scenes/drum/A.toml --set particles.seed=$seed" \
         "--set integrator.dt=$dt --set run.rotations=1000 --set run.snapshot_every=100 --set run.profile_every=1" \
         "--checkpoint-every 5"
  done; done >"$jobs"
  for scene in "$dir"/src/scenes/drum/*.toml; do
    "$dir/engine/granular" info "$scene" --json | /usr/bin/python3 -c '
import json, sys
j = json.load(sys.stdin)
d, rot = j["derived"], j["run"]["rotations"]
snap = max(10, round(rot / 10 / 10) * 10)
prof = max(1, round(rot / 5000))
print(d["particles"] * d["steps_total"], sys.argv[1], sys.argv[2], rot, snap, prof)' "$dir/runs/$(basename "$scene" .toml).h5" "$scene"
  done | sort -g | while read -r _ out scene rot snap prof; do
    # #J and #K: the paper's Fig. 9 averages 10 configurations near the end
    case "$(basename "$scene")" in J.toml|K.toml) final="--set run.final_snapshots=10" ;; *) final="" ;; esac
    echo "$out $scene --set run.rotations=$rot --set run.snapshot_every=$snap --set run.profile_every=$prof $final --checkpoint-every 5"
  done >>"$jobs"
fi

GRANULAR_BIN="$dir/engine/granular" exec "$here/scripts/campaign.sh" "$jobs" "$lanes"
exit
}
