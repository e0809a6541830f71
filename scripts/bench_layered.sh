#!/usr/bin/env bash
# Benchmark of the --subsurface modes on the Lee Perry-Smith head with the skin stack bound by
# --materials (scenes/lee_perry_smith_head/skin_map.json). Small resolution so it stays feasible
# on 2 cores: for each mode, seconds, rays/s, scattering events and the RMSE against a
# high-sample random-walk reference; the time to reach a target RMSE is extrapolated with
# RMSE ~ 1/sqrt(spp) (valid for the unbiased random-walk; the other modes converge to their
# bias, reported as their RMSE floor). Writes out/bench_layered/results.txt.
# Environment: BENCH_W, BENCH_H, BENCH_REF_SPP, BENCH_SPP (list), BENCH_TARGET (RMSE).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
LAMINA="$BUILD_DIR"/renderer/lamina
W=${BENCH_W:-48}; H=${BENCH_H:-60}
REF_SPP=${BENCH_REF_SPP:-256}
SPPS=${BENCH_SPP:-"4 16"}
TARGET=${BENCH_TARGET:-0.01}
OUT=${BENCH_OUT:-out/bench_layered}
mkdir -p "$OUT"
SCENE=scenes/lee_perry_smith_head/head_lit.gltf
MAP=scenes/lee_perry_smith_head/skin_map.json
COMMON=(--width "$W" --height "$H" --materials "$MAP" --env 0.1 --camera portrait)
log="$OUT/results.txt"
: > "$log"
if [ ! -f "$OUT/reference.exr" ]; then
  "$LAMINA" render "$SCENE" "${COMMON[@]}" --spp "$REF_SPP" --seed 1000 --subsurface random-walk -o "$OUT/reference.exr" \
    | tee -a "$log"
fi
for mode in random-walk first-order table lambert; do
  for spp in $SPPS; do
    out="$OUT/$mode-$spp.exr"
    line=$("$LAMINA" render "$SCENE" "${COMMON[@]}" --spp "$spp" --seed 1 --subsurface "$mode" -o "$out")
    secs=$(echo "$line" | sed -n 's/.* spp, \([0-9.]*\) s;.*/\1/p' | head -1)
    rays=$(echo "$line" | sed -n 's/.*closest-hit (.*) = \([0-9.e+]*\)\/s, \([0-9.e+]*\) shadow.*/\1 \2/p' | head -1)
    events=$(echo "$line" | sed -n 's/.*material(s), \([0-9.e+]*\) scattering events.*/\1/p')
    rmse=$("$LAMINA" compare "$OUT/reference.exr" "$out" -o "$OUT/diff-$mode-$spp.exr" | sed -n 's/.*RMSE \([0-9.e+-]*\).*/\1/p')
    extra=$(echo "$line" | grep -E "table mode|lambert mode: albedos" | tr '\n' ' ' || true)
    echo "mode=$mode spp=$spp seconds=$secs closest_rays_per_s,shadow=$rays shadow_total=$(echo "$line" | sed -n 's/.*), [0-9.e+]*\/s, \([0-9.e+]*\) shadow.*/\1/p' | head -1) events=${events:-0} rmse=$rmse $extra" | tee -a "$log"
    python3 - "$secs" "$rmse" "$TARGET" "$events" "$mode" "$spp" <<'PY' | tee -a "$log"
import sys
secs, rmse, target = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
events = float(sys.argv[4] or 0)
t = secs * (rmse / target) ** 2
print(f"  -> {sys.argv[5]} {sys.argv[6]} spp: time to RMSE {target} (if unbiased) ~ {t:.1f} s;"
      + (f" cost per scattering event {1e9 * secs / events:.0f} ns (all of the render / events)" if events > 0 else ""))
PY
  done
done
echo "bench_layered: wrote $log"
