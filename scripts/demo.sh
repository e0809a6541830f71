#!/usr/bin/env bash
# Installs what is missing, builds, and renders the default scenes into out/ (EXR + PNG).
# Within 10 minutes on 2 cores: the layered head renders for what is left of a 9-minute budget
# (LAMINA_DEMO_BUDGET, below). LAMINA_DEMO_SPP overrides the samples per pixel.
set -euo pipefail
cd "$(dirname "$0")/.."
DEMO_START=$(date +%s)
scripts/setup.sh
LAMINA_BUILD_TARGET=lamina scripts/build.sh  # the renderer only; scripts/test.sh builds the tests
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
LAMINA="$BUILD_DIR"/renderer/lamina
SPP=${LAMINA_DEMO_SPP:-128}
mkdir -p out
echo "demo: built $("$LAMINA" --version)"
# Every PNG is tone mapped (filmic, the default of --tone-curve); the EXRs stay linear. Renders
# that are denoised keep the albedo and normal AOVs (--aovs), and lamina denoise writes the
# denoised image beside the raw one (*_denoised.exr/.png).
"$LAMINA" render scenes/cornell_box/CornellBox.glb -o out/cornell_box.exr --png out/cornell_box.png \
  --width 512 --height 512 --spp "$SPP" --aovs albedo,normal
"$LAMINA" denoise out/cornell_box.exr -o out/cornell_box_denoised.exr --png out/cornell_box_denoised.png
"$LAMINA" render scenes/lee_perry_smith_head/head_lit.gltf -o out/head.exr --png out/head.png \
  --width 480 --height 600 --spp "$SPP" --env 0.1
# glTF metallic-roughness: gold and red plastic spheres from roughness 0.05 to 1.
"$LAMINA" render scenes/metal_dielectric/metal_dielectric.gltf -o out/metal_dielectric.exr --png out/metal_dielectric.png \
  --width 480 --height 300 --spp "${LAMINA_DEMO_SPP:-64}" --env 0.15
# Lambert against layered (the paper's figure): a skin sphere, light at 0 and 45 degrees; about
# half a minute on 2 cores (LAMINA_DEMO_SPHERES_SPP overrides the samples per pixel). The
# difference is shown smoothed (Gaussian, sigma 2 px, stated in its legend): at 256 spp a pixel's
# noise is still ~14 % against a pattern of about +-20 %, smoothed ~2 %.
SPHERES_SPP=${LAMINA_DEMO_SPHERES_SPP:-256}
for angle in 0 45; do
  for mode in random-walk lambert; do
    "$LAMINA" render scenes/spheres/spheres_$angle.gltf -o out/spheres_${angle}_$mode.exr \
      --png out/spheres_${angle}_$mode.png --width 80 --height 80 --spp "$SPHERES_SPP" --subsurface $mode
  done
  "$LAMINA" compare out/spheres_${angle}_lambert.exr out/spheres_${angle}_random-walk.exr \
    -o out/spheres_${angle}_difference.exr --png out/spheres_${angle}_difference.png --smooth 2 --range 0.3
done
# Layered materials (random walk per shading point: slower per sample, so fewer samples).
# LAMINA_DEMO_SPP, if set, overrides these too.
LEAF_SPP=${LAMINA_DEMO_SPP:-32}
# The portrait (480x600, front key + rim light): the textured glTF head (the asset's photograph as
# its albedo, normal map) | the layered head (skin_oily.json, melanin, blood and sebum maps fitted
# to the same photographs; --subsurface auto at tolerance 0.01: tables where they are within 1 %,
# raw, no denoiser) | their difference, smoothed (Gaussian, sigma 1 px, stated in its legend): what
# light scattering under the skin changes for the same person.
"$LAMINA" render scenes/head_skin/head_textured.gltf -o out/head_textured.exr --png out/head_textured.png \
  --width 480 --height 600 --spp "$SPP" --env 0.05
"$LAMINA" render scenes/head_skin/head_skin.gltf -o out/head_skin_auto.exr --png out/head_skin_auto.png \
  --width 480 --height 600 --spp "${LAMINA_DEMO_SPP:-64}" --env 0.05 --subsurface auto --tolerance 0.01
"$LAMINA" compare out/head_textured.exr out/head_skin_auto.exr --png out/head_difference.png --smooth 1 --range 0.5
oiiotool out/head_textured.png out/head_skin_auto.png out/head_difference.png --mosaic 3x1 -o out/portrait.png
# The unbiased walk, the reference the fast modes are measured against: two independent renders
# (seeds 1 and 2), each for half of what is left of the demo's budget, LAMINA_DEMO_BUDGET seconds
# from the start (default 540: 9 of the 10 minutes), after what came before and 45 s for the renders
# after it; each half at least 30 s, at most 300 s (LAMINA_DEMO_HEAD_SECONDS sets a half directly).
# Their difference measures the noise of one: RMSE(a - b) / sqrt(2) / mean, over the image. The first
# is written raw with that figure on it (out/head_skin.png) and denoised beside it.
DEMO_BUDGET=${LAMINA_DEMO_BUDGET:-540}
HEAD_SECONDS=${LAMINA_DEMO_HEAD_SECONDS:-$(( (DEMO_BUDGET - ($(date +%s) - DEMO_START) - 45) / 2 ))}
HEAD_SECONDS=$(( HEAD_SECONDS < 30 ? 30 : HEAD_SECONDS > 300 ? 300 : HEAD_SECONDS ))
echo "demo: the walk renders the head twice for $HEAD_SECONDS s ($(( $(date +%s) - DEMO_START )) s into the demo; budget $DEMO_BUDGET s)"
for seed in 1 2; do
  "$LAMINA" render scenes/head_skin/head_skin.gltf -o out/head_skin_walk_$seed.exr --png out/head_skin_walk_$seed.png \
    --width 480 --height 600 --spp "${LAMINA_DEMO_SPP:-4096}" --time-limit "$HEAD_SECONDS" --env 0.05 \
    --seed $seed --aovs albedo,normal
done
"$LAMINA" compare out/head_skin_walk_1.exr out/head_skin_walk_2.exr --json out/head_skin_noise.json > /dev/null
NOISE=$(python3 -c "import json, math; j = json.load(open('out/head_skin_noise.json'))
print(f\"{100 * j['rmse'] / math.sqrt(2) / (j['guard_floor'] / j['guard_epsilon']):.1f}\")")
SPP_TAKEN=$(printf '%.0f' "$(oiiotool --info -v out/head_skin_walk_1.exr | sed -n 's/.*lamina:mean_spp: "\(.*\)"/\1/p')")
echo "demo: the walk's head: $SPP_TAKEN spp in $HEAD_SECONDS s, relative noise (RMSE / mean) $NOISE %"
mv out/head_skin_walk_1.exr out/head_skin.exr
"$LAMINA" denoise out/head_skin.exr -o out/head_skin_denoised.exr --png out/head_skin_denoised.png
oiiotool out/head_skin_walk_1.png --text:x=12:y=30:size=18:color=1,1,1:font=/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf \
  "walk, $SPP_TAKEN spp in $HEAD_SECONDS s: noise $NOISE %" -o out/head_skin.png
rm -f out/head_skin_walk_1.png out/head_skin_walk_2.exr out/head_skin_walk_2.png
# Leaves lit from the front and from behind, then side by side: leaf_rough.json, rough cuticles on
# both faces (energy-conserving rough interfaces, alpha 0.3).
for side in front back; do
  "$LAMINA" render scenes/leaves/leaves_${side}_rough.gltf -o out/leaves_$side.exr --png out/leaves_$side.png \
    --width 320 --height 240 --spp "$LEAF_SPP" --aovs albedo,normal
  "$LAMINA" denoise out/leaves_$side.exr -o out/leaves_${side}_denoised.exr --png out/leaves_${side}_denoised.png
done
oiiotool out/leaves_front_denoised.png out/leaves_back_denoised.png --mosaic 2x1 -o out/leaves.png
# A leaf as a Blender user exports it: alpha-masked cards with KHR_materials_diffuse_transmission,
# mapped onto a layered stack with no stack file (docs/gltf_materials.md), front- and back-lit.
for side in front back; do
  "$LAMINA" render scenes/gltf_leaf/gltf_leaf_$side.gltf -o out/gltf_leaf_$side.exr --png out/gltf_leaf_$side.png \
    --width 240 --height 180 --spp "${LAMINA_DEMO_SPP:-64}" --env 0.03
done
oiiotool out/gltf_leaf_front.png out/gltf_leaf_back.png --mosaic 2x1 -o out/gltf_leaf.png
echo "demo: wrote out/cornell_box, out/head, out/metal_dielectric, out/spheres_{0,45}_*, out/head_skin (the walk), out/head_skin_auto, out/head_difference, out/leaves_front, out/leaves_back (.exr, .png; *_denoised beside the denoised ones), out/portrait.png, out/leaves.png and out/gltf_leaf.png"
