#!/usr/bin/env bash
# `lamina brdf` against MCML 2.0 (Wang and Jacques' C code) on three slabs (a, b, c): photons
# per CPU-second, one core each, interleaved runs (the machine is shared and noisy), medians, and
# the totals of both so that the speed is compared at the same answer. Not run by the test suite.
#
#   bench/mcml_compare.sh [LAMINA]        (default build/renderer/lamina)
#
# MCML is fetched from https://github.com/lhvwang/MCML at 97574f3 into $MC_OUT/MCML.git (or taken
# from MCML_SRC, any clone of that repository, bare or not) and built with gcc -O3, after making
# FindDataLine's line buffer static: it returns a pointer to a local array, which gcc 12
# optimises into a null pointer.
# Environment: MC_RUNS (interleaved runs, default 3), MC_SLABS (default "a b c"), MC_OUT
# (default out/mcml_compare), MC_SCALE (photon counts times this, default 1).
#
# The slabs (MCML works in cm and 1/cm, Lamina in mm and 1/mm; normal incidence, n 1 above
# and below):
#   a  van de Hulst's slab: n 1, sigma_a 1, sigma_s 9 /mm, g 0.75, 0.2 mm (MCML's sample1a)
#   b  Giovanelli's half-space: n 1.5, sigma_a 1, sigma_s 9 /mm, g 0 (MCML's sample1b)
#   c  skin-like, three layers of n 1.4: 0.1 mm (0.3 / 30 / 0.8), 1 mm (0.05 / 20 / 0.8),
#      a half-space (0.01 / 12 / 0.9)  (sigma_a / sigma_s in 1/mm, g)
set -euo pipefail
cd "$(dirname "$0")/.."
LAMINA=${1:-build/renderer/lamina}
OUT=${MC_OUT:-out/mcml_compare}
RUNS=${MC_RUNS:-3}
SLABS=${MC_SLABS:-"a b c"}
SCALE=${MC_SCALE:-1}
[ -x "$LAMINA" ] || { echo "mcml_compare: no lamina binary at $LAMINA" >&2; exit 2; }
mkdir -p "$OUT"

# ---- MCML ----
MCML_COMMIT=97574f3
MCML="$OUT/mcml"
if [ ! -x "$MCML" ]; then
  repo=${MCML_SRC:-$OUT/MCML.git}  # any clone of the repository, bare or not
  [ -n "${MCML_SRC:-}" ] || [ -d "$repo" ] || git clone -q --bare https://github.com/lhvwang/MCML "$repo"
  tmp=$(mktemp -d)
  git -C "$repo" archive "$MCML_COMMIT" V2/MCML2.0 | tar -x -C "$tmp"
  code="$tmp/V2/MCML2.0"
  # FindDataLine's `char buf[STRLEN];` (the first such declaration after its name) becomes static.
  awk '/^FindDataLine\(FILE/ {inside = 1}
       inside && /char[ \t]+buf\[STRLEN\];/ {sub(/char/, "static char"); inside = 0}
       {print}' "$code/mcmlio.c" > "$tmp/mcmlio.c" && mv "$tmp/mcmlio.c" "$code/mcmlio.c"
  grep -q 'static char[ \t]*buf\[STRLEN\]' "$code/mcmlio.c" || { echo "mcml_compare: could not patch FindDataLine" >&2; exit 2; }
  gcc -O3 -o "$MCML" "$code"/*.c -lm
  rm -rf "$tmp"
fi

# ---- inputs ----
photons() { case "$1" in a) echo $((2000000 * SCALE)) ;; b) echo $((1000000 * SCALE)) ;; c) echo $((20000 * SCALE)) ;; esac; }
write_inputs() {
  local slab=$1 n=$2 dir="$OUT/$1"
  mkdir -p "$dir"
  local media geometry json
  case "$slab" in
    a) media="slab 1.0 10 90 0.75"; geometry="slab 0.02"
       json='{"lamina_material": 1, "name": "mcml_a", "layers": [{"ior": 1.0, "thickness": 0.2, "sigma_a": 1, "sigma_s": 9, "g": 0.75}], "below": {"ior": 1.0}}' ;;
    b) media="slab 1.5 10 90 0"; geometry="slab 1E8"
       json='{"lamina_material": 1, "name": "mcml_b", "layers": [{"ior": 1.5, "thickness": "inf", "sigma_a": 1, "sigma_s": 9, "g": 0}]}' ;;
    c) media=$'epi 1.4 3 300 0.8\n  derm 1.4 0.5 200 0.8\n  deep 1.4 0.1 120 0.9'
       geometry=$'epi 0.01\n  derm 0.1\n  deep 1E8'
       json='{"lamina_material": 1, "name": "mcml_c", "layers": [
  {"ior": 1.4, "thickness": 0.1, "sigma_a": 0.3, "sigma_s": 30, "g": 0.8},
  {"ior": 1.4, "thickness": 1.0, "sigma_a": 0.05, "sigma_s": 20, "g": 0.8},
  {"ior": 1.4, "thickness": "inf", "sigma_a": 0.01, "sigma_s": 12, "g": 0.9}]}' ;;
  esac
  echo "$json" > "$dir/stack.json"
  cat > "$dir/slab.mci" <<EOF
mcmli2.0
# name n mua mus g  (1/cm)
  air 1.0 0 0 0
  $media
end
slab.mco A
# medium thickness (cm)
  air
  $geometry
  air
end
pencil
0
0.01 0.01 0.1
1 1 1 30
Rd_a Td_a
$n 100:00
1E-4
1
end
EOF
}

cpu_seconds() {  # CPU seconds (user + sys) of a command on one core
  local f
  f=$(mktemp)
  /usr/bin/time -o "$f" -f "%U %S" taskset -c 0 "$@" >/dev/null 2>&1
  awk '{ printf "%.3f", $1 + $2 }' "$f"
  rm -f "$f"
}
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

printf '%-5s %10s %12s %12s %22s   %s\n' slab photons "MCML CPU s" "lamina CPU s" "lamina/MCML photons/s" "diffuse R: MCML | lamina (+- s.e.)"
for slab in $SLABS; do
  n=$(photons "$slab")
  write_inputs "$slab" "$n"
  dir="$OUT/$slab"
  t_mcml="" t_lamina=""
  for ((run = 0; run < RUNS; ++run)); do
    t_mcml+="$( cd "$dir" && cpu_seconds "$OLDPWD/$MCML" slab.mci ) "
    t_lamina+="$(cpu_seconds "$LAMINA" brdf "$dir/stack.json" --theta-i 0 --samples "$n" --summary "$dir/lamina.json") "
  done
  m_mcml=$(echo "$t_mcml" | median)
  m_lamina=$(echo "$t_lamina" | median)
  rd_mcml=$(awk '/#Rd:/ {print $1 " +- " $2; exit}' "$dir/slab.mco")
  rd_lamina=$(python3 -c "import json; s = json.load(open('$dir/lamina.json')); print('%.6g +- %.6g' % (s['R_diffuse'][0], s['R_diffuse_stderr'][0]))")
  ratio=$(awk -v a="$m_mcml" -v b="$m_lamina" 'BEGIN { printf "%.2f", a / b }')
  printf '%-5s %10s %12s %12s %22s   %s | %s\n' "$slab" "$n" "$m_mcml" "$m_lamina" "$ratio" "$rd_mcml" "$rd_lamina"
  echo "  runs: MCML $t_mcml| lamina $t_lamina"
done
