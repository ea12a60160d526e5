#!/usr/bin/env bash
# The shaken box at the paper's lengths (docs/shaken_box.md, "At the paper's
# lengths"): the runs, then the figures and tables.
#
#   scripts/box_long.sh [DIR] [LANES]          runs (restartable) into DIR/runs, report into DIR/report
#   scripts/box_long.sh [DIR] [LANES] forces   the force-ratio runs only, and their table
#   scripts/box_long.sh [DIR] [LANES] ramps    the ramp runs only, and their table
#
# DIR defaults to /var/lib/granular/box. Every run is a shipped scene at its
# defaults (the leapfrog, 2e-4 s) with the packing (particles.seed) and the
# quantity studied overridden:
#   fig4_R{2.0,3.0}_sS    Fig. 4: R = 2 and 3 cm at 3.2 Hz, 120 s, packings 1-12
#   f{2.6,2.8,3.0}_{big,nobig}_sS   Figs. 1 and 3: 60 s, packings 1-6
#   ramp_{up,down}_nobig_sS        the ramp, 0.005 Hz/s, packings 1-16
#   slowramp_{up,down}_nobig_s1    the ramp ten times slower, 0.0005 Hz/s
#   R4_gapG_sS            R = 4 cm at 3.2 Hz placed with its bottom G cm above the floor, packings 1-6
#                         (60 s; 40 s from G = 10 on)
#   force_f{2.45,2.6,2.65,2.7,2.8}_{big,nobig}_sS  the force ratio: 30 s, 8 frames a cycle, packings 1-30
# About 2.5 core-hours on this machine, the force-ratio runs (300) about 45 core-minutes,
# the ramps (32 and 2 slow ones) about 1 core-hour.
# The body is one block, read whole before it runs: editing this file while
# the job runs (it runs from the working tree) cannot change what it does.
{
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$(realpath -m "${1:-/var/lib/granular/box}")"
lanes="${2:-2}"
only="${3:-}"
case "$only" in ""|forces|ramps) ;; *) echo "box_long.sh: the third argument is forces, ramps or nothing, not $only" >&2; exit 2 ;; esac
S="$here/scenes/box"
O="$dir/runs"
mkdir -p "$O" "$dir/report"
jobs="$dir/jobs_all.txt"
{
  for s in $(seq 1 12); do for R in 2.0 3.0; do
    echo "$O/fig4_R${R}_s$s.h5 $S/R${R}_f3.2.toml --set particles.seed=$s --set run.duration=120"; done; done
  for s in $(seq 1 16); do for d in up down; do
    echo "$O/ramp_${d}_nobig_s$s.h5 $S/ramp_$d.toml --set particles.seed=$s --set big.enabled=false"; done; done
  for f in 2.6 2.8 3.0; do for s in 1 2 3 4 5 6; do for k in big nobig; do
    echo "$O/f${f}_${k}_s$s.h5 $S/f${f}_$k.toml --set particles.seed=$s"; done; done; done
  for g in 2.5 4.5 6.5 10 15 20; do for s in 1 2 3 4 5 6; do
    length=60; [ "${g%.*}" -ge 10 ] && length=40  # the higher placements rise within 13 s
    echo "$O/R4_gap${g}_s$s.h5 $S/R4.0_f3.2.toml --set particles.seed=$s --set big.gap=$g --set run.duration=$length"
  done; done
  for d in up down; do
    echo "$O/slowramp_${d}_nobig_s1.h5 $S/ramp_$d.toml --set big.enabled=false --set shaking.ramp_time=2000 --set run.duration=2020"
  done
  for s in $(seq 1 30); do for f in 2.45 2.6 2.65 2.7 2.8; do for k in big nobig; do
    echo "$O/force_f${f}_${k}_s$s.h5 $S/f2.8_$k.toml --set shaking.frequency=$f --set particles.seed=$s --set run.duration=30 --set run.snapshot_every_cycles=0.125"
  done; done; done
} >"$jobs"
if [ "$only" = forces ]; then
  grep "/force_f" "$jobs" >"$dir/jobs_forces.txt"
  jobs="$dir/jobs_forces.txt"
elif [ "$only" = ramps ]; then
  grep "ramp_" "$jobs" >"$dir/jobs_ramps.txt"
  jobs="$dir/jobs_ramps.txt"
fi
CAMPAIGN_NICE="${CAMPAIGN_NICE:-5}" "$here/scripts/campaign.sh" "$jobs" "$lanes"

cd "$here"
if [ "$only" = forces ]; then
  /usr/bin/python3 -m compare box-forces --big "$O"/force_f*_big_s*.h5 --nobig "$O"/force_f*_nobig_s*.h5 \
    >"$dir/report/forces.md"
  echo "report in $dir/report/forces.md"
  exit 0
fi
if [ "$only" = ramps ]; then
  /usr/bin/python3 -m compare box-report --ramp "$O"/ramp_*_nobig_s*.h5 "$O"/slowramp_*_nobig_s1.h5 \
    -o "$dir/report" >"$dir/report/ramps.md"
  echo "report in $dir/report/ramps.md"
  exit 0
fi
/usr/bin/python3 -m compare box-report --height "$O"/fig4_R*.h5 \
  --big "$O"/f2.6_big_s*.h5 "$O"/f2.8_big_s*.h5 "$O"/f3.0_big_s*.h5 \
  --nobig "$O"/f2.6_nobig_s*.h5 "$O"/f2.8_nobig_s*.h5 "$O"/f3.0_nobig_s*.h5 \
  --velocity "$O"/f2.6_nobig_s1.h5 "$O"/f3.0_nobig_s1.h5 "$O"/f3.0_big_s1.h5 \
  --ramp "$O"/ramp_*_nobig_s*.h5 "$O"/slowramp_*_nobig_s1.h5 \
  -o "$dir/report" >"$dir/report/summary.md"
/usr/bin/python3 -m compare box-placement "$O"/R4_gap*_s*.h5 >"$dir/report/placement.md"
/usr/bin/python3 -m compare box-forces --big "$O"/force_f*_big_s*.h5 --nobig "$O"/force_f*_nobig_s*.h5 \
  >"$dir/report/forces.md"
echo "report in $dir/report"
exit
}
