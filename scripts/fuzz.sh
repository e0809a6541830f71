#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang, ASan and UBSan, and runs each for a bounded
# time from a seed corpus of the repository's own files (tests/corpus and the scenes).
#
# usage: scripts/fuzz.sh [--seconds N] [--jobs J] [TARGET...]
#   TARGET: fuzz_gltf, fuzz_material, fuzz_manifest, fuzz_image (default: all four)
#   --seconds N: per target (default 600); --jobs J: targets run at once (default 1)
# Outputs in build-fuzz/ (LAMINA_FUZZ_DIR overrides): corpus/<target>/ (grows across runs),
# findings/<target>/ (crash-*, leak-*, timeout-*, oom-* inputs), logs/<target>.log. Memory:
# -rss_limit_mb=2048, which is also libFuzzer's limit on one allocation (OpenEXR 3.1 reserves
# about 1.1 GB for some corrupt headers before it refuses them, resident memory staying ~150 MB). Prints per
# target the executions, executions per second, coverage (libFuzzer's "cov": instrumented edges
# reached) and the findings; exits 1 if any target has a finding. A finding becomes a regression
# case in tests/corpus (README there) once fixed.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET=600
JOBS=1
TARGETS=()
while [ $# -gt 0 ]; do
  case $1 in
    --seconds) SECONDS_PER_TARGET=$2; shift 2 ;;
    --jobs) JOBS=$2; shift 2 ;;
    fuzz_gltf | fuzz_material | fuzz_manifest | fuzz_image) TARGETS+=("$1"); shift ;;
    *) echo "usage: scripts/fuzz.sh [--seconds N] [--jobs J] [fuzz_gltf|fuzz_material|fuzz_manifest|fuzz_image ...]" >&2; exit 2 ;;
  esac
done
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(fuzz_gltf fuzz_material fuzz_manifest fuzz_image)

scripts/setup.sh
# Debian bookworm's clang 14, its libFuzzer and its sanitizer runtimes (pinned by the release,
# like every package of scripts/setup.sh; libclang-rt-14-dev is only "recommended" by clang-14,
# so --no-install-recommends leaves ASan's libraries out); only this script needs them.
missing=()
for p in clang-14 libfuzzer-14-dev libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}" ||
    { $SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"; }
fi

DIR=${LAMINA_FUZZ_DIR:-build-fuzz}
if [ ! -f "$DIR/build.ninja" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S . -B "$DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLAMINA_FUZZ=ON \
    -DLAMINA_BUILD_TESTS=OFF -DLAMINA_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$DIR" -j "$(nproc)" --target "${TARGETS[@]}"

# Seeds: the files each reader is meant for, valid and hostile.
seed() {
  local target=$1 dest="$DIR/corpus/$1"
  mkdir -p "$dest"
  case $target in
    fuzz_gltf) find tests/corpus/gltf scenes -maxdepth 2 \( -name '*.gltf' -o -name '*.glb' \) -size -2M ;;
    fuzz_material) find tests/corpus scenes/materials scenes/batch/stacks -name '*.json' ! -name '*.cases.json' -size -64k ;;
    fuzz_manifest) find scenes/batch -maxdepth 1 -name '*.json' ;;
    fuzz_image) find tests/corpus/images scenes -maxdepth 2 \( -name '*.exr' -o -name '*.png' -o -name '*.hdr' \) -size -64k ;;
  esac 2>/dev/null | while read -r f; do cp -n "$f" "$dest/seed_$(basename "$f")" 2>/dev/null || true; done
}

run() {
  local target=$1
  seed "$target"
  mkdir -p "$DIR/findings/$target" "$DIR/logs"
  # Relative paths in manifests and glTF files resolve against the seeds' own folders: run in
  # scenes/batch so a manifest's "../x.gltf" names a real scene.
  # Leaks inside third-party libraries are suppressed by scripts/lsan.supp, which needs whole
  # stacks through them (they have no frame pointers): the slow unwinder for the image reader.
  local unwind=1
  [ "$target" = fuzz_image ] && unwind=0
  (cd scenes/batch && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:fast_unwind_on_malloc=$unwind \
    LSAN_OPTIONS=suppressions=$OLDPWD/scripts/lsan.supp:print_suppressions=0 UBSAN_OPTIONS=halt_on_error=1 \
    "$OLDPWD/$DIR/fuzz/$target" -max_total_time="$SECONDS_PER_TARGET" -timeout=20 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$OLDPWD/$DIR/findings/$target/" \
    "$OLDPWD/$DIR/corpus/$target" >"$OLDPWD/$DIR/logs/$target.log" 2>&1) || true
  local execs rate cov found
  # (libFuzzer prints its final stats twice when a run ends in a finding: the last counts.)
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$DIR/logs/$target.log" | tail -1 | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$DIR/logs/$target.log" | tail -1 | grep -o '[0-9]*$' || echo 0)
  cov=$(grep -o 'cov: [0-9]*' "$DIR/logs/$target.log" | tail -1 | grep -o '[0-9]*' || echo 0)
  found=$(find "$DIR/findings/$target" -type f | wc -l)
  echo "fuzz: $target: ${SECONDS_PER_TARGET} s, ${execs:-0} executions (${rate:-0}/s), coverage ${cov:-0} edges, $found finding(s) in $DIR/findings/$target/"
}

export -f run seed
export DIR SECONDS_PER_TARGET
printf '%s\n' "${TARGETS[@]}" | xargs -P "$JOBS" -I{} bash -c 'run {}' | tee "$DIR/summary.txt"
if grep -q ' [1-9][0-9]* finding(s)' "$DIR/summary.txt"; then
  echo "fuzz: findings: reproduce one with $DIR/fuzz/<target> <file>"
  exit 1
fi
