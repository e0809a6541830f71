#!/usr/bin/env bash
# Installs what is missing, builds, and renders the default scenes into out/ (EXR + PNG).
# A few minutes on 2 cores. LAMINA_DEMO_SPP overrides the samples per pixel.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
LAMINA="$BUILD_DIR"/renderer/lamina
SPP=${LAMINA_DEMO_SPP:-128}
mkdir -p out
echo "demo: built $("$LAMINA" --version)"
"$LAMINA" render scenes/cornell_box/CornellBox.glb -o out/cornell_box.exr --png out/cornell_box.png \
  --width 512 --height 512 --spp "$SPP"
"$LAMINA" render scenes/lee_perry_smith_head/head_lit.gltf -o out/head.exr --png out/head.png \
  --width 400 --height 500 --spp "$SPP" --env 0.1
echo "demo: wrote out/cornell_box.{exr,png} and out/head.{exr,png}"
