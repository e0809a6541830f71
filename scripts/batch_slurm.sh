#!/usr/bin/env bash
# Runs a `lamina batch` as a Slurm job array: one array task per shard, then a finalize job that
# starts once every task has succeeded (afterok dependency).
#
#   scripts/batch_slurm.sh MANIFEST.json OUT_DIR SHARDS [extra sbatch options...]
#
# Submits (from a login node): the array `--array=0-(SHARDS-1)`, whose task k runs
#   lamina batch MANIFEST --out OUT_DIR --shard k/SHARDS --threads $SLURM_CPUS_PER_TASK
# and the finalize job `lamina batch MANIFEST --out OUT_DIR --finalize`. The manifest, its scenes,
# OUT_DIR and the lamina binary (LAMINA, default build/renderer/lamina here) must be on a file
# system every node sees. Extra arguments go to both sbatch calls (e.g. --partition=cpu,
# --cpus-per-task=8, --time=02:00:00). Not tested in Lamina's CI (no Slurm there); see
# docs/batch.md.
set -euo pipefail

if [ "$#" -lt 3 ]; then
  echo "usage: $0 MANIFEST.json OUT_DIR SHARDS [sbatch options...]" >&2
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
lamina=$(realpath "${LAMINA:-$(dirname "$0")/../build/renderer/lamina}")
if [ ! -x "$lamina" ]; then
  echo "$0: $lamina: no lamina binary (build it or set LAMINA)" >&2
  exit 2
fi
# Fail here, not on the cluster, for a bad manifest.
"$lamina" batch "$manifest" --out "$out" --list > /dev/null
mkdir -p "$out/slurm"

array_id=$(sbatch --parsable "$@" --job-name=lamina-batch --array="0-$((shards - 1))" \
  --output="$out/slurm/shard-%a.log" \
  --wrap="\"$lamina\" batch \"$manifest\" --out \"$out\" --shard \${SLURM_ARRAY_TASK_ID}/$shards --threads \${SLURM_CPUS_PER_TASK:-0}")
final_id=$(sbatch --parsable "$@" --job-name=lamina-batch-finalize --dependency="afterok:${array_id}" \
  --output="$out/slurm/finalize.log" \
  --wrap="\"$lamina\" batch \"$manifest\" --out \"$out\" --finalize")
echo "submitted: shards array ${array_id} (${shards} tasks), finalize ${final_id}; logs in $out/slurm/"
