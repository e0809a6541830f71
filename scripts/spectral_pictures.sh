#!/usr/bin/env bash
# The pictures of docs/spectral.md, "Spectral rendering": head_skin and the back-lit leaves
# rendered in the RGB mode and with --spectral (the same seed and samples), and the relative
# difference of their luminance (`lamina compare`, smoothed by a Gaussian of sigma 1 px, which its
# legend states), side by side: docs/images/spectral_head_skin.png and
# docs/images/spectral_leaves_back.png. About 5 minutes on 2 cores.
# Then the leaves by pigment (scenes/leaves_spectral, written by
# scripts/make_leaves_spectral_scene.py: five chlorophyll contents, from green to yellowing),
# front and back lit, the RGB mode rendering each leaf's RGB projection (the scene's material
# map): docs/images/spectral_leaves_pigment_{front,back}.png. About 6 minutes more.
#
#   scripts/spectral_pictures.sh        SP_SPP (default 64) sets the samples per pixel;
#                                       SP_ONLY=leaves renders only the leaves by pigment
set -euo pipefail
cd "$(dirname "$0")/.."
LAMINA=${LAMINA_BUILD_DIR:-build}/renderer/lamina
SPP=${SP_SPP:-64}
OUT=${SP_OUT:-out/spectral_pictures}
mkdir -p "$OUT" docs/images

picture() {  # NAME SCENE ARGS...
  local name=$1 scene=$2
  shift 2
  for mode in rgb spectral; do
    local args=()
    [ "$mode" = rgb ] && args=("${RGB_ARGS[@]}")
    [ "$mode" = spectral ] && args=(--spectral)
    "$LAMINA" render "$scene" "$@" --spp "$SPP" "${args[@]}" -o "$OUT/${name}_$mode.exr" --png "$OUT/${name}_$mode.png"
  done
  "$LAMINA" compare "$OUT/${name}_rgb.exr" "$OUT/${name}_spectral.exr" --png "$OUT/${name}_difference.png" --smooth 1 \
    --range 0.2 --json "$OUT/${name}_difference.json"
  oiiotool "$OUT/${name}_rgb.png" "$OUT/${name}_spectral.png" "$OUT/${name}_difference.png" --mosaic 3x1 \
    -o "docs/images/spectral_$name.png"
}

RGB_ARGS=()
if [ "${SP_ONLY:-}" != leaves ]; then
  picture head_skin scenes/head_skin/head_skin.gltf --width 240 --height 300 --env 0.05
  picture leaves_back scenes/leaves/leaves_back.gltf --width 320 --height 240
fi

# The leaves by pigment: the RGB mode cannot read leaf layers, so it renders their projection.
RGB_ARGS=(--materials scenes/leaves_spectral/leaves_rgb_materials.json)
for side in front back; do
  picture "leaves_pigment_$side" "scenes/leaves_spectral/leaves_spectral_$side.gltf" --width 240 --height 180
done
