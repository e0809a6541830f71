#!/usr/bin/env bash
# The spectral mode's cost against the RGB mode's, to the same luminance noise (not run by the
# test suite; docs/spectral.md quotes it). Renders a scene in both modes with K seeds each,
# interleaved (rgb, spectral, rgb, ...: the machine is shared), measures each mode's relative
# luminance noise per image over the seeds with bench/colour_noise (no reference needed: it is
# noise, not error, and the two modes differ a little in colour on purpose) and the render
# seconds of each image (`lamina:seconds`, the render loop without scene loading), and prints
#   cost ratio = (sd_spectral^2 t_spectral) / (sd_rgb^2 t_rgb)
# the spectral mode's time to the RGB mode's luminance noise, over the RGB mode's (variance
# falls as 1/time for a Monte Carlo render).
#
#   bench/spectral_cost.sh [SCENE.gltf]      default scenes/head_skin/head_skin.gltf
# Environment: SC_SIZE (WxH, default 64x80), SC_SPP (default 64), SC_SEEDS (default 4),
# SC_THREADS (default 1), SC_OUT (default out/spectral_cost), SC_ARGS (more `lamina render`
# arguments for both modes, e.g. "--subsurface auto --tolerance 0.05 --cache out/spectral_cost/cache").
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
LAMINA=$BUILD_DIR/renderer/lamina
NOISE=$BUILD_DIR/bench/colour_noise
SCENE=${1:-scenes/head_skin/head_skin.gltf}
SIZE=${SC_SIZE:-64x80}
W=${SIZE%x*}; H=${SIZE#*x}
SPP=${SC_SPP:-64}
SEEDS=${SC_SEEDS:-4}
THREADS=${SC_THREADS:-1}
OUT=${SC_OUT:-out/spectral_cost}
read -r -a EXTRA <<< "${SC_ARGS:-}"
mkdir -p "$OUT"
for exe in "$LAMINA" "$NOISE"; do
  [ -x "$exe" ] || { echo "spectral_cost: $exe is not built (cmake --build $BUILD_DIR --target lamina colour_noise)" >&2; exit 2; }
done

declare -A seconds=([rgb]=0 [spectral]=0)
for seed in $(seq 1 "$SEEDS"); do
  for mode in rgb spectral; do
    args=()
    [ "$mode" = spectral ] && args=(--spectral)
    line=$("$LAMINA" render "$SCENE" --width "$W" --height "$H" --spp "$SPP" --seed "$seed" --threads "$THREADS" \
      "${args[@]}" "${EXTRA[@]}" -o "$OUT/${mode}_$seed.exr" 2>/dev/null | grep -- ' -> ')
    # "... WxH, N spp, S s; rays ..."
    s=$(sed -E 's/.* spp, ([0-9.e+-]+) s;.*/\1/' <<< "$line")
    seconds[$mode]=$(python3 -c "print(${seconds[$mode]} + $s)")
  done
done

noise() { "$NOISE" "$OUT/$1"_*.exr | sed -nE 's/^seed_sd +Y ([0-9.]+).*/\1/p'; }
sd_rgb=$(noise rgb)
sd_spectral=$(noise spectral)
python3 - "$SCENE" "$SIZE" "$SPP" "$SEEDS" "$sd_rgb" "$sd_spectral" "${seconds[rgb]}" "${seconds[spectral]}" <<'PY'
import sys
scene, size, spp, seeds = sys.argv[1:5]
sd_r, sd_s, t_r, t_s = map(float, sys.argv[5:9])
n = int(seeds)
print(f'{scene} {size} {spp} spp, {n} seeds per mode')
print(f'rgb       luminance noise {sd_r:.4f}  seconds per image {t_r / n:.3f}')
print(f'spectral  luminance noise {sd_s:.4f}  seconds per image {t_s / n:.3f}')
print(f'time ratio {t_s / t_r:.3f}  variance ratio {(sd_s / sd_r) ** 2:.3f}  '
      f'cost ratio to the same luminance noise {(sd_s ** 2 * t_s) / (sd_r ** 2 * t_r):.3f}')
PY
