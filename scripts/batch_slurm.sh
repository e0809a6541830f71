#!/usr/bin/env bash
# Runs a `lamina batch` as a Slurm job array: one array task per shard, then a finalize job that
# starts once every task has succeeded (afterok dependency).
#
#   scripts/batch_slurm.sh [--wait] MANIFEST.json OUT_DIR SHARDS [extra sbatch options...]
#
# Submits (from a login node): the array `--array=0-(SHARDS-1)`, whose task k runs
#   lamina batch MANIFEST --out OUT_DIR --shard k/SHARDS --threads <the task's CPUs>
# and the finalize job `lamina batch MANIFEST --out OUT_DIR --finalize`, which Slurm cancels if a
# task fails. Logs go to OUT_DIR/slurm/. The manifest, its scenes, OUT_DIR and the lamina binary
# (LAMINA, default build/renderer/lamina here) must be on a file system every node sees. Extra
# arguments go to both sbatch calls (e.g. --partition=cpu, --cpus-per-task=8, --time=02:00:00).
#
# Without --wait it exits once both are submitted (0, or 2 for bad arguments or a bad manifest).
# With --wait it then blocks until the finalize job has ended and exits 0 only if every task and
# the finalize job completed with exit code 0; otherwise it names what failed and exits 1.
# Tested by tests/renderer/cli/test_batch_slurm.cpp on a private local cluster (scripts/lib/local_slurm.sh);
# see docs/batch.md.
set -euo pipefail

usage="usage: $0 [--wait] MANIFEST.json OUT_DIR SHARDS [sbatch options...]"
wait_for_end=0
while [ "$#" -gt 0 ]; do
  case "$1" in
    --wait) wait_for_end=1; shift ;;
    -h | --help) echo "$usage"; exit 0 ;;
    *) break ;;
  esac
done
if [ "$#" -lt 3 ]; then
  echo "$usage" >&2
  exit 2
fi
if [ ! -f "$1" ]; then
  echo "$0: $1: no such manifest" >&2
  exit 2
fi
manifest=$(realpath "$1")
out=$(realpath -m "$2")
shards=$3
shift 3
case "$shards" in
  '' | *[!0-9]*) echo "$0: SHARDS must be a positive integer, got '$shards'" >&2; exit 2 ;;
esac
if [ "$shards" -lt 1 ]; then
  echo "$0: SHARDS must be at least 1" >&2
  exit 2
fi
lamina=$(realpath -m "${LAMINA:-$(dirname "$0")/../build/renderer/lamina}")
if [ ! -x "$lamina" ]; then
  echo "$0: $lamina: no lamina binary (build it or set LAMINA)" >&2
  exit 2
fi
for exe in sbatch scontrol; do
  if ! command -v "$exe" > /dev/null; then
    echo "$0: $exe not found: run this on a Slurm login node" >&2
    exit 2
  fi
done
# Fail here, not on the cluster, for a bad manifest.
"$lamina" batch "$manifest" --out "$out" --list > /dev/null || exit 2
mkdir -p "$out/slurm"

# The job scripts are run by /bin/sh: single-quote each path so spaces, quotes or `$` in it are
# taken literally.
sh_quote() { printf "'%s'" "$(printf '%s' "$1" | sed "s/'/'\\\\''/g")"; }
q_lamina=$(sh_quote "$lamina")
q_manifest=$(sh_quote "$manifest")
q_out=$(sh_quote "$out")

# Threads: --cpus-per-task when given, else the CPUs Slurm gave the task on its node (never 0,
# which would mean every core of a node other jobs share).
array_id=$(sbatch --parsable "$@" --job-name=lamina-batch --array="0-$((shards - 1))" \
  --chdir="$out" --output="$out/slurm/shard-%a.log" \
  --wrap="exec $q_lamina batch $q_manifest --out $q_out --shard \${SLURM_ARRAY_TASK_ID}/$shards --threads \${SLURM_CPUS_PER_TASK:-\${SLURM_CPUS_ON_NODE:-1}}")
array_id=${array_id%%;*}  # --parsable prints `id;cluster` on multi-cluster set-ups
# --kill-on-invalid-dep: if a task fails the dependency can never be met; without it the
# finalize job would stay pending for ever (DependencyNeverSatisfied).
final_id=$(sbatch --parsable "$@" --job-name=lamina-batch-finalize --dependency="afterok:${array_id}" \
  --kill-on-invalid-dep=yes --chdir="$out" --output="$out/slurm/finalize.log" \
  --wrap="exec $q_lamina batch $q_manifest --out $q_out --finalize")
final_id=${final_id%%;*}
echo "submitted: shards array ${array_id} (${shards} tasks), finalize ${final_id}; logs in $out/slurm/"
[ "$wait_for_end" = 1 ] || exit 0

# One line per job (per array task, or per still-pending range of tasks):
# `id array-task state exit-code`, array-task `-` for a job that is not an array's.
job_states() {
  scontrol show job --oneliner "$1" | awk '{
    id = ""; task = "-"; state = ""; code = ""
    for (i = 1; i <= NF; ++i) {
      eq = index($i, "="); key = substr($i, 1, eq - 1); value = substr($i, eq + 1)
      if (key == "JobId" && id == "") id = value
      else if (key == "ArrayTaskId" && task == "-") task = value
      else if (key == "JobState" && state == "") state = value
      else if (key == "ExitCode" && code == "") code = value
    }
    if (id != "") print id, task, state, code
  }'
}
is_finished() {
  case "$1" in
    COMPLETED | FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY | BOOT_FAIL | DEADLINE | PREEMPTED) return 0 ;;
    *) return 1 ;;
  esac
}
# Every line of $1 finished?
all_finished() {
  local id task state code
  while read -r id task state code; do
    is_finished "$state" || return 1
  done <<< "$1"
}

# The finalize job ends last (it runs after the array, or is cancelled when a task fails); then
# the array's records. scontrol keeps finished jobs for MinJobAge (300 s by default), far longer
# than this polls: every second for the first minute, then every 10 s (one query per poll, so a
# long batch does not load the controller).
errors=0
polls=0
while :; do
  if ! final=$(job_states "$final_id" 2> /dev/null); then
    errors=$((errors + 1))
    if [ "$errors" -ge 30 ]; then
      echo "$0: cannot read the state of job $final_id from scontrol (30 tries)" >&2
      exit 1
    fi
  elif [ -n "$final" ] && all_finished "$final"; then
    break
  else
    errors=0
  fi
  polls=$((polls + 1))
  if [ "$polls" -le 60 ]; then sleep 1; else sleep 10; fi
done
array=$(job_states "$array_id") || { echo "$0: cannot read the state of job array $array_id" >&2; exit 1; }
while ! all_finished "$array"; do  # tasks still completing when finalize was cancelled
  sleep 1
  array=$(job_states "$array_id")
done

status=0
while read -r id task state code; do
  if [ "$state" != COMPLETED ] || [ "$code" != 0:0 ]; then
    echo "$0: shard $task (job $id): $state, exit code $code; see $out/slurm/shard-$task.log" >&2
    status=1
  fi
done <<< "$array"
read -r _ _ state code <<< "$final"
if [ "$state" != COMPLETED ] || [ "$code" != 0:0 ]; then
  echo "$0: finalize (job $final_id): $state, exit code $code; see $out/slurm/finalize.log" >&2
  status=1
fi
[ "$status" = 0 ] && echo "done: every shard and the finalize job completed; outputs in $out"
exit "$status"
