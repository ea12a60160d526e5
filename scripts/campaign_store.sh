#!/usr/bin/env bash
# Keeps a long background job's state in the repository, so that it outlives
# the machine it runs on: the job's commit and what it has produced are copied
# into campaign/NAME/ and committed there; a job started where its directory is
# missing continues from that copy (scripts/table1_campaign.sh,
# scripts/validate_full.sh).
#
#   scripts/campaign_store.sh save NAME [DIR]      copy DIR's state into campaign/NAME/ and commit it
#   scripts/campaign_store.sh restore NAME [DIR]   copy campaign/NAME/ into DIR, where DIR holds no job
#   scripts/campaign_store.sh stop NAME [DIR]      stop the job (SIGTERM: its engines write their
#                                                  checkpoints first), e.g. before a save that ends the day
#
# NAME is the job; DIR defaults to /var/lib/granular/NAME. Kept: DIR/COMMIT
# (the engine is rebuilt from it, scripts/pin_commit.sh), and
#   table1:         DIR/jobs.txt and DIR/runs (outputs, logs, .done marks, and the
#                   checkpoints of the runs not finished);
#   validate_full:  each finished run's metadata with its observables,
#                   DIR/out/runs/*.json (compare/validate.py, "kept observables");
#                   not the runs' outputs, nor the reports DIR/out/report*, which
#                   `compare validate` makes again from the kept observables.
# The files are copied with the job's engines stopped (SIGSTOP, then SIGCONT),
# so that each is copied as it was at one moment: an output is written in
# HDF5's single-writer/multiple-reader mode, consistent at every moment, and a
# checkpoint replaces the previous one in one rename after the output rows it
# records are flushed.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
verb="${1:?save or restore}"; name="${2:?job name}"
dir="$(realpath -m "${3:-/var/lib/granular/$name}")"
store="$here/campaign/$name"

kept() {  # the files of DIR to keep, relative to it
  (cd "$1" && case "$name" in
    validate_full) find ./out/runs -maxdepth 1 -name '*.json' -type f 2>/dev/null ;;
    *) find ./jobs.txt ./runs -type f ! -name '*.tmp' ! -name '*.resuming' 2>/dev/null |
         while read -r f; do  # a finished run's last checkpoint is not needed to go on
           case "$f" in *.h5.ckpt) [ -e "${f%.ckpt}.done" ] && continue ;; esac
           echo "$f"
         done ;;
  esac) | sed 's|^\./||'
}

copy_state() {  # FROM TO: COMMIT and the kept files; TO's earlier copy is replaced as a whole
  local from="$1" to="$2"
  rm -rf "$to.new"
  mkdir -p "$to.new"
  cp -p "$from/COMMIT" "$to.new/COMMIT"
  (cd "$from" && kept "$from" | tr '\n' '\0' | xargs -0 -r cp -p --parents -t "$to.new")
  rm -rf "$to"
  mv "$to.new" "$to"
}

case "$verb" in
  save)
    [ -e "$dir/COMMIT" ] || { echo "campaign_store: no job in $dir (no COMMIT)" >&2; exit 2; }
    mapfile -t pids < <(pgrep -f "^$dir/engine/granular " || true)
    resume() { ((${#pids[@]})) && kill -CONT "${pids[@]}" 2>/dev/null || :; }
    trap resume EXIT
    ((${#pids[@]})) && kill -STOP "${pids[@]}" 2>/dev/null || :
    copy_state "$dir" "$store"
    resume
    trap - EXIT
    cd "$here"
    git add -A -f "campaign/$name"
    if git diff --cached --quiet -- "campaign/$name"; then
      echo "campaign_store: campaign/$name unchanged"
    else
      git commit -q -m "campaign/$name: runs as of $(date -u +%Y-%m-%dT%H:%MZ)" -- "campaign/$name"
      echo "campaign_store: campaign/$name committed ($(du -sh "$store" | cut -f1))"
    fi
    ;;
  restore)
    if [ -e "$dir/COMMIT" ]; then exit 0; fi
    [ -e "$store/COMMIT" ] || exit 0
    mkdir -p "$(dirname "$dir")"
    copy_state "$store" "$dir"
    echo "campaign_store: $dir restored from campaign/$name (commit $(cat "$dir/COMMIT"))"
    ;;
  stop)
    # The job's processes: every process sharing a setsid group (SID) with
    # one whose command line names DIR (the pinned engine, the job list, the
    # suite's output); the job is started by setsid, as the README says. Never
    # this shell's own group, and never SID 0: ps shows 0 for a group whose
    # leader lies outside this PID namespace (a container), and pkill -s 0
    # would mean this shell's own group.
    own="$(ps -o sid= -p $$ | tr -d ' ')"
    mapfile -t sids < <(ps -eo sid=,args= | awk -v d="$dir/" 'index($0, d) {print $1}' | sort -u | grep -vx -e "$own" -e 0 || true)
    if ((${#sids[@]} == 0)); then echo "campaign_store: no $name job running"; exit 0; fi
    for s in "${sids[@]}"; do pkill -TERM -s "$s" || :; done
    for _ in $(seq 120); do
      alive=0
      for s in "${sids[@]}"; do  # a process that has exited but not been reaped (Z) is gone
        ps -o stat= --sid "$s" | grep -qv '^Z' && alive=1
      done
      ((alive)) || break
      sleep 0.5
    done
    ((alive)) && { echo "campaign_store: $name still running after 60 s" >&2; exit 1; }
    echo "campaign_store: $name stopped (SID ${sids[*]}); it resumes from its checkpoints when started again"
    ;;
  *) echo "campaign_store: unknown verb $verb (save, restore or stop)" >&2; exit 2 ;;
esac
