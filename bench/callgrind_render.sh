#!/bin/sh
# Instruction counts (valgrind --tool=callgrind) of bench_render's render loop and its Embree
# ceiling: robust to the machine's load, unlike wall clock. Prints instructions per ray.
#   bench/callgrind_render.sh BUILD_DIR [SCENE ...]
#   env: LAMINA_BENCH_SIZE (default 128 here), LAMINA_BENCH_SPP, LAMINA_BENCH_CAMERA
#        (scene | framed; default scene), LAMINA_CG_REPLAY=1 (also count the replay of all
#        the loop's rays: Embree's instructions per ray for the loop's own ray mix)
set -eu
build=${1:?usage: callgrind_render.sh BUILD_DIR [SCENE ...]}
shift
[ $# -gt 0 ] || set -- /work/shared/assets/stanford_bunny/bunny.glb \
  "$(dirname "$0")/../scenes/lee_perry_smith_head/head_lit.gltf"
export LAMINA_BENCH_SIZE=${LAMINA_BENCH_SIZE:-128} LAMINA_BENCH_REPEAT=1
[ -n "${LAMINA_CG_REPLAY:-}" ] || export LAMINA_BENCH_NO_REPLAY=1
export LAMINA_BENCH_CAMERA=${LAMINA_BENCH_CAMERA:-scene}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for scene in "$@"; do
  valgrind --tool=callgrind --callgrind-out-file="$out/cg" \
    "--toggle-collect=*timed_render*" "--toggle-collect=*ceiling_loop*" "--toggle-collect=*replay_loop*" \
    "$build/bench/bench_render" "$scene" >"$out/log" 2>"$out/err"
  rays=$(sed -nE 's/.*render loop: ([0-9]+) rays.*/\1/p' "$out/log")
  camera=$(sed -nE 's/.*ceiling \(camera rays, rtcIntersect1\): ([0-9]+) rays.*/\1/p' "$out/log")
  callgrind_annotate --inclusive=yes "$out/cg" 2>/dev/null | tr -d , >"$out/ann"
  loop_ir=$(grep -E "\?\?\?:\(anonymous namespace\)::timed_render" "$out/ann" | awk '{print $1}')
  ceil_ir=$(grep -E "\?\?\?:\(anonymous namespace\)::ceiling_loop" "$out/ann" | awk '{print $1}')
  replay_ir=$(grep -E "\?\?\?:\(anonymous namespace\)::replay_loop" "$out/ann" | awk '{print $1}')
  echo "$scene ($LAMINA_BENCH_CAMERA camera, ${LAMINA_BENCH_SIZE}^2):"
  grep -E "rays hit" "$out/log"
  awk -v r="$rays" -v c="$camera" -v l="$loop_ir" -v e="$ceil_ir" 'BEGIN {
    printf "    render loop: %d instructions / %d rays = %.0f per ray\n", l, r, l / r;
    printf "    ceiling:     %d instructions / %d rays = %.0f per ray\n", e, c, e / c;
    printf "    ratio (instructions per ray, ceiling / loop): %.1f%%\n", 100 * (e / c) / (l / r) }'
  [ -z "$replay_ir" ] || awk -v r="$rays" -v c="$camera" -v e="$ceil_ir" -v p="$replay_ir" 'BEGIN {
    printf "    replay:      %d instructions / %d rays = %.0f per ray (zero-overhead bound on the ratio: %.1f%%)\n",
      p, r, p / r, 100 * (e / c) / (p / r) }'
done
