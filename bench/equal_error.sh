#!/usr/bin/env bash
# Equal-error speed-up of the random walk between two lamina builds (not run by the
# test suite). Renders each scene with both builds over a ladder of spp, interleaved
# old/new in one run (the machine is shared and noisy), against a long reference by the new
# build, and prints per scene the relative luminance RMSE and seconds of every image and the
# equal-error speed-up t_old(E) / t_new(E) at E = 5 % (bench/equal_error.cpp has the estimator).
#
#   bench/equal_error.sh [OLD_LAMINA [NEW_LAMINA]]
#
# OLD_LAMINA: default, the parent commit of HEAD built into $EQ_OUT/baseline-<sha> (a git
# worktree; built once and kept). NEW_LAMINA: default build/renderer/lamina.
# Environment: EQ_SCENES (default "head_skin spheres_45 leaves_back"; or paths of .gltf files), EQ_SIZE (WxH, default
# 64x80), EQ_SPP (default "16 64 256": at 5 % these builds need 1,000-2,000 spp, and a heavy-
# tailed walk's variance is underestimated by renders far below that), EQ_REPEAT (renders of each
# spp per build with the odd seeds 2 (spp + 1000 r) + 1, never the reference's 1000, default 2:
# the seed pairs measure each build's variance without the reference), EQ_REF_SPP (default
# 4096), EQ_TARGET (default 0.05),
# EQ_OUT (default out/equal_error), EQ_ARGS (extra arguments for the NEW build only, e.g.
# "--similarity-after 0" to measure an approximate option against the exact old one),
# EQ_COMMON_ARGS (extra arguments for both builds and the reference, e.g. "--env 0.05"; they
# name the outputs, so references with other arguments are not reused).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
OUT=${EQ_OUT:-out/equal_error}
SCENES=${EQ_SCENES:-"head_skin spheres_45 leaves_back"}
SIZE=${EQ_SIZE:-64x80}
W=${SIZE%x*}; H=${SIZE#*x}
SPPS=${EQ_SPP:-"16 64 256"}
REPEAT=${EQ_REPEAT:-2}
REF_SPP=${EQ_REF_SPP:-4096}
TARGET=${EQ_TARGET:-0.05}
read -r -a NEW_ARGS <<< "${EQ_ARGS:-}"
read -r -a COMMON_ARGS <<< "${EQ_COMMON_ARGS:-}"
TAG=$(printf '%s' "${EQ_COMMON_ARGS:-}" | tr -c 'A-Za-z0-9.' '_')  # names the outputs
mkdir -p "$OUT"

OLD=${1:-}
NEW=${2:-$BUILD_DIR/renderer/lamina}
if [ -z "$OLD" ]; then
  sha=$(git rev-parse --short HEAD~1)
  src="$OUT/baseline-$sha"
  if [ ! -x "$src/build/renderer/lamina" ]; then
    echo "equal_error: building the baseline $sha in $src" >&2
    [ -d "$src" ] || git worktree add --detach "$src" "$sha" >/dev/null
    cmake -S "$src" -B "$src/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLAMINA_BUILD_BENCH=OFF >/dev/null
    cmake --build "$src/build" --target lamina >/dev/null
  fi
  OLD="$src/build/renderer/lamina"
fi
[ -x "$OLD" ] && [ -x "$NEW" ] || { echo "equal_error: need two lamina binaries (old: $OLD, new: $NEW)" >&2; exit 2; }
METRIC="$BUILD_DIR/bench/equal_error"
[ -x "$METRIC" ] || cmake --build "$BUILD_DIR" --target equal_error >/dev/null

scene_path() {
  case "$1" in
    head_skin) echo scenes/head_skin/head_skin.gltf ;;
    head_skin_procedural) echo scenes/head_skin/head_skin_procedural.gltf ;;
    spheres_0|spheres_45) echo "scenes/spheres/$1.gltf" ;;
    leaves_front|leaves_back) echo "scenes/leaves/$1.gltf" ;;
    *.gltf|*.glb) [ -f "$1" ] && echo "$1" || { echo "equal_error: no scene $1" >&2; exit 2; } ;;
    *) echo "equal_error: unknown scene $1" >&2; exit 2 ;;
  esac
}

for scene in $SCENES; do
  path=$(scene_path "$scene")
  scene=$(basename "${scene%.*}")${TAG:+_$TAG}  # a glTF path: its file name names the outputs
  ref="$OUT/ref_${scene}_${W}x${H}_${REF_SPP}.exr"
  if [ ! -f "$ref" ]; then
    echo "equal_error: reference $ref ($REF_SPP spp, new build)" >&2
    "$NEW" render "$path" --width "$W" --height "$H" --spp "$REF_SPP" --seed 1000 ${COMMON_ARGS[@]+"${COMMON_ARGS[@]}"} -o "$ref" >/dev/null
  fi
  old_images=(); new_images=()
  for ((r = 0; r < REPEAT; ++r)); do
    for spp in $SPPS; do
      seed=$((2 * (spp + 1000 * r) + 1)); tag=$spp; [ "$r" -eq 0 ] || tag=${spp}_$r
      o="$OUT/${scene}_old_$tag.exr"; n="$OUT/${scene}_new_$tag.exr"
      "$OLD" render "$path" --width "$W" --height "$H" --spp "$spp" --seed "$seed" ${COMMON_ARGS[@]+"${COMMON_ARGS[@]}"} -o "$o" >/dev/null
      "$NEW" render "$path" --width "$W" --height "$H" --spp "$spp" --seed "$seed" ${COMMON_ARGS[@]+"${COMMON_ARGS[@]}"} "${NEW_ARGS[@]}" -o "$n" >/dev/null
      old_images+=("$o"); new_images+=("$n")
    done
  done
  echo "== $scene ${W}x${H}, spp $SPPS x $REPEAT, reference $REF_SPP spp ${EQ_COMMON_ARGS:+(both: $EQ_COMMON_ARGS) }${EQ_ARGS:+(new: $EQ_ARGS)}"
  "$METRIC" --target "$TARGET" "$ref" "${old_images[@]}" -- "${new_images[@]}"
done
