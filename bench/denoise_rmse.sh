#!/usr/bin/env bash
# Denoising against long references: for each scene, a reference at REF_SPP,
# then renders at each of SPP_LADDER with --aovs albedo,normal, each denoised by lamina denoise;
# prints RMSE (and luminance relative RMSE) of raw and denoised against the reference, the render
# and denoise seconds, and writes the PNGs (filmic) into OUT for docs/performance.md.
# Usage: bench/denoise_rmse.sh [LAMINA] [OUT]   (about 10 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
LAMINA=${1:-build/renderer/lamina}
OUT=${2:-out/denoise}
REF_SPP=${REF_SPP:-1024}
SPP_LADDER=${SPP_LADDER:-"4 16 64"}
mkdir -p "$OUT"
scenes=(
  "cornell|scenes/cornell_box/CornellBox.glb|--width 160 --height 160"
  "leaves_back|scenes/leaves/leaves_back.gltf|--width 160 --height 120"
  "head_skin_procedural|scenes/head_skin/head_skin_procedural.gltf|--width 120 --height 150 --env 0.05"
)
seconds() { sed -n 's/.*, \([0-9.]*\) s; rays.*/\1/p'; }
rmse() { "$LAMINA" compare "$1" "$2" --json "$OUT/cmp.json" >/dev/null && python3 -c "import json; j = json.load(open('$OUT/cmp.json')); print(f\"{j['rmse']:.5g} {j['rms_relative']:.4f}\")"; }
printf '%-12s %5s %9s %9s %9s %9s %8s %8s\n' scene spp rmse_raw rel_raw rmse_dn rel_dn render_s denoise_s
for entry in "${scenes[@]}"; do
  IFS='|' read -r name scene args <<<"$entry"
  ref="$OUT/${name}_ref.exr"
  [ -f "$ref" ] || "$LAMINA" render "$scene" -o "$ref" --png "$OUT/${name}_ref.png" $args --spp "$REF_SPP" >/dev/null 2>&1
  for spp in $SPP_LADDER; do
    raw="$OUT/${name}_${spp}.exr"
    t_render=$("$LAMINA" render "$scene" -o "$raw" --png "$OUT/${name}_${spp}.png" $args --spp "$spp" --seed 5 --aovs albedo,normal 2>/dev/null | seconds)
    t_denoise=$("$LAMINA" denoise "$raw" -o "$OUT/${name}_${spp}_denoised.exr" --png "$OUT/${name}_${spp}_denoised.png" |
      sed -n 's/.*, \([0-9.]*\) s (Open.*/\1/p')
    read -r r_raw rel_raw <<<"$(rmse "$ref" "$raw")"
    read -r r_dn rel_dn <<<"$(rmse "$ref" "$OUT/${name}_${spp}_denoised.exr")"
    printf '%-12s %5s %9s %9s %9s %9s %8s %8s\n' "$name" "$spp" "$r_raw" "$rel_raw" "$r_dn" "$rel_dn" "$t_render" "$t_denoise"
  done
done
