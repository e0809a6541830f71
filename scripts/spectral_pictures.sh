#!/usr/bin/env bash
# The pictures of docs/spectral.md, "Spectral rendering": head_skin and the back-lit leaves
# rendered in the RGB mode and with --spectral (the same seed and samples), and the relative
# difference of their luminance (`lamina compare`, smoothed by a Gaussian of sigma 1 px, which its
# legend states), side by side: docs/images/spectral_head_skin.png and
# docs/images/spectral_leaves_back.png; and head_spectral, the head given by chromophores with
# melanin and blood maps fitted spectrally to its albedo photo (scenes/head_skin/head_skin_spectral.gltf,
# scripts/make_head_spectral_scene.py) at the portrait's 480 x 600: docs/images/spectral_head_spectral.png.
# About 5 minutes on 2 cores for the first two, 15 for head_spectral.
# Then the leaves by pigment (scenes/leaves_spectral, written by
# scripts/make_leaves_spectral_scene.py: five chlorophyll contents, from green to yellowing),
# front and back lit, the RGB mode rendering each leaf's fitted RGB reading (the scene's material
# map), at 160 x 120 with SP_LEAF_SPP samples (default 1024, chosen by the leaves' measured noise,
# docs/spectral.md "Leaves by pigment"): docs/images/spectral_leaves_pigment_{front,back}.png; and
# leaves_yellowing, the back-lit fan whose chlorophyll comes from a map, in the spectral mode
# alone (the RGB mode reads no leaf layers): docs/images/spectral_leaves_yellowing.png. About
# 15 minutes more on the 2 shared cores.
#
#   scripts/spectral_pictures.sh [NAME...]   only the pictures named (head_skin, leaves_back, head_spectral,
#                                            leaves_pigment_front, leaves_pigment_back, leaves_yellowing)
#                                            SP_SPP (default 64) sets the samples per pixel,
#                                            SP_LEAF_SPP (default 1024) those of the last three
set -euo pipefail
cd "$(dirname "$0")/.."
LAMINA=${LAMINA_BUILD_DIR:-build}/renderer/lamina
SPP=${SP_SPP:-64}
OUT=${SP_OUT:-out/spectral_pictures}
SELECTED=("$@")
mkdir -p "$OUT" docs/images

picture() {  # NAME SCENE ARGS...
  local name=$1 scene=$2
  shift 2
  if [ ${#SELECTED[@]} -gt 0 ] && [[ ! " ${SELECTED[*]} " == *" $name "* ]]; then return 0; fi
  for mode in rgb spectral; do
    local args=()
    [ "$mode" = rgb ] && args=("${RGB_ARGS[@]}")
    [ "$mode" = spectral ] && args=(--spectral)
    "$LAMINA" render "$scene" "$@" --spp "$SPP" "${args[@]}" -o "$OUT/${name}_$mode.exr" --png "$OUT/${name}_$mode.png"
  done
  "$LAMINA" compare "$OUT/${name}_rgb.exr" "$OUT/${name}_spectral.exr" --png "$OUT/${name}_difference.png" --smooth 1 \
    --range 0.2 --json "$OUT/${name}_difference.json"
  # Each panel fitted to FIT (WxH) if set: small renders shown enlarged, beside the difference
  # map, whose legend is wider than they are.
  local fit=()
  [ -n "${FIT:-}" ] && fit=(--fit:filter=box "$FIT")
  oiiotool "$OUT/${name}_rgb.png" "${fit[@]}" "$OUT/${name}_spectral.png" "${fit[@]}" "$OUT/${name}_difference.png" \
    "${fit[@]}" --mosaic 3x1 -o "docs/images/spectral_$name.png"
}

RGB_ARGS=()
picture head_skin scenes/head_skin/head_skin.gltf --width 240 --height 300 --env 0.05
picture leaves_back scenes/leaves/leaves_back.gltf --width 320 --height 240
picture head_spectral scenes/head_skin/head_skin_spectral.gltf --width 480 --height 600 --env 0.05
# Beside it, the textures: the albedo photo (512 x 512, as the maps were fitted to it) | the colour
# the spectrally fitted maps give | the colour head_skin's RGB-fitted maps give.
if [ ${#SELECTED[@]} -eq 0 ] || [[ " ${SELECTED[*]} " == *" head_spectral "* ]]; then
  oiiotool scenes/lee_perry_smith_head/Map-COL.jpg --resize 512x512 scenes/head_skin/fitted_albedo_spectral.png \
    scenes/head_skin/fitted_albedo.png --mosaic 3x1 --resize 768x256 -o docs/images/head_spectral_albedo.png
fi

# The leaves by pigment: the RGB mode cannot read leaf layers, so it renders their fitted RGB reading.
SPP=${SP_LEAF_SPP:-1024}
RGB_ARGS=(--materials scenes/leaves_spectral/leaves_rgb_materials.json)
FIT=320x240  # the 160 x 120 renders shown at twice their size
for side in front back; do
  picture "leaves_pigment_$side" "scenes/leaves_spectral/leaves_spectral_$side.gltf" --width 160 --height 120
done
# The leaf whose chlorophyll comes from a map (docs/stack_bindings.md, "Leaf parameters").
if [ ${#SELECTED[@]} -eq 0 ] || [[ " ${SELECTED[*]} " == *" leaves_yellowing "* ]]; then
  "$LAMINA" render scenes/leaves_spectral/leaves_yellowing_back.gltf --width 160 --height 120 --spp "$SPP" --spectral \
    -o "$OUT/leaves_yellowing_spectral.exr" --png "$OUT/leaves_yellowing_spectral.png"
  oiiotool "$OUT/leaves_yellowing_spectral.png" --fit:filter=box "$FIT" -o docs/images/spectral_leaves_yellowing.png
fi
