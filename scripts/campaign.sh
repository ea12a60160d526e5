#!/usr/bin/env bash
# Runs the long native runs behind docs/table1.md and docs/shaken_box.md.
#   scripts/campaign.sh JOBFILE [LANES]
# JOBFILE holds one job per line: OUTPUT.h5 SCENE [granular run options...]
# A job whose OUTPUT.h5.done exists is skipped, so the campaign can be
# restarted; a job interrupted after its first checkpoint (OUTPUT.h5.ckpt)
# continues from it (--resume), any other leftover is started again (--force).
# Each job writes OUTPUT.log beside its output. The engine is $GRANULAR_BIN, or
# build/granular (scripts/table1_campaign.sh pins one built from a fixed commit),
# at niceness $CAMPAIGN_NICE (default 19). Where the kernel groups processes
# for scheduling by setsid (autogroups, /proc/sys/kernel/sched_autogroup_enabled),
# niceness ranks a process only within its group and the groups share the
# cores equally; a campaign started by setsid (`setsid scripts/table1_campaign.sh`,
# a group of its own) gives its group the same niceness, so that it yields the
# cores to interactive work. Started otherwise, it leaves alone the group it
# shares with whatever started it.
# The body is one block, read whole before it runs: editing this file while
# the job runs (it runs from the working tree) cannot change what it does.
{
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bin="${GRANULAR_BIN:-$here/build/granular}"
niceness="${CAMPAIGN_NICE:-19}"  # yields the cores to interactive work
jobs="$1"; lanes="${2:-2}"
if [ "$(ps -o sid= -p $$ | tr -d ' ')" = "$$" ]; then
  echo "$niceness" >/proc/self/autogroup 2>/dev/null || :
fi
run_one() {
  out="$1"; shift; scene="$1"; shift
  [ -e "$out.done" ] && exit 0
  mkdir -p "$(dirname "$out")"
  mode=--force
  [ -e "$out" ] && [ -e "$out.ckpt" ] && mode=--resume
  if nice -n "$niceness" "$bin" run "$scene" -o "$out" $mode --threads 1 -q "$@" >>"${out%.h5}.log" 2>&1; then
    touch "$out.done"
  else
    echo "failed: $out (see ${out%.h5}.log)" >&2
  fi
}
export -f run_one; export here bin niceness
grep -v '^\s*#' "$jobs" | grep -v '^\s*$' | xargs -P "$lanes" -L 1 bash -c 'run_one "$@"' _
exit
}
