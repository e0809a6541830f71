#!/usr/bin/env bash
# compare_builds.sh OLD_LAMINA NEW_LAMINA [WORKDIR]
#
# "No behaviour change" check for a refactor: runs two builds of lamina on the same small inputs
# and requires identical results. Everything Lamina does is deterministic for a fixed seed (for any
# thread count), so anything that differs is a change in behaviour, not noise.
#
# Checks (one output line each, "ok" or "DIFFERENT"):
#   version   `lamina --version` (it is part of every batch job hash)
#   render    for each scene/mode below, at --seed 3 and --threads 1 and 2:
#             - pixels of OLD vs NEW: `lamina compare --json`, MAE must be exactly 0
#             - console of OLD vs NEW: exit status, stdout and stderr, after removing timings
#               (seconds, rays/s, peak memory) and the build's own output directory
#             - EXR header of OLD vs NEW: every key, and every value except lamina:seconds,
#               lamina:command and DateTime (a wall clock)
#             - pixels of NEW at 1 thread vs NEW at 2 threads (MAE 0)
#             Scenes: the Cornell box; head_skin in every --subsurface mode (random-walk,
#             first-order, table, lambert, auto --tolerance 0.05); the back-lit leaves; the
#             spheres at 0 and 45 degrees in random-walk and lambert (as scripts/demo.sh does).
#             Plus: NEW's table-mode head with tables built afresh at 2 threads equals the one
#             whose tables were built at 1 thread (the 2-thread runs above reuse the cache).
#   brdf      for each preset stack scenes/materials/*.json, --method monte-carlo (20000
#             photons) and first-order at theta_i 30: the CSV, the summary JSON and the console
#             must be byte-identical. (The summary JSON has no timing field, so nothing is
#             dropped from it.)
#   batch     `lamina batch MANIFEST --list` for each scenes/batch/*.json: identical job indices,
#             ids and hashes; and each of those batches run small (24x24, spp / 32): the same
#             job EXRs (pixels, headers with timings ignored), comparisons, jobs.json, variant
#             stacks and summary.csv less its timing columns.
# Ends with "N passed, M failed"; exits 1 if anything failed (2 for bad usage).
#
# Images are small (64x48 or 48x48, 2-4 spp): a minute or two on 2 cores, most of it the table
# mode's random walk at 1 thread. Each build has its own --cache directory (cache keys contain the
# executable's build id, so sharing would not reuse anything); its 2-thread runs reuse what its
# 1-thread runs built. Comparisons use OLD's `lamina compare` (the trusted baseline).
# All outputs go under WORKDIR (default: a new mktemp -d); old/, new/ and cmp/ in it are
# replaced on each run. Run from anywhere: the script works from the repository root.
set -euo pipefail

usage() {
  echo "usage: $0 OLD_LAMINA NEW_LAMINA [WORKDIR]" >&2
  exit 2
}
[[ $# -ge 2 && $# -le 3 ]] || usage
abspath() { case $1 in /*) printf '%s\n' "$1" ;; *) printf '%s/%s\n' "$PWD" "$1" ;; esac; }
OLD=$(abspath "$1")
NEW=$(abspath "$2")
for exe in "$OLD" "$NEW"; do
  [[ -x $exe ]] || { echo "$0: not an executable: $exe" >&2; exit 2; }
done
if [[ $# -eq 3 ]]; then
  mkdir -p -- "$3"
  WORKDIR=$(cd -- "$3" && pwd)
else
  WORKDIR=$(mktemp -d "${TMPDIR:-/tmp}/compare_builds.XXXXXX")
fi
cd "$(dirname "$0")/.."

SEED=3
THREADS=(1 2)
CMP="$WORKDIR/cmp"   # normalised copies, diffs and compare JSONs
rm -rf -- "$WORKDIR/old" "$WORKDIR/new" "$CMP"
mkdir -p -- "$WORKDIR"/{old,new}/{render,brdf,batch} "$CMP"
echo "compare_builds: OLD $OLD" >&2
echo "compare_builds: NEW $NEW" >&2
echo "compare_builds: outputs in $WORKDIR" >&2

exe_of() { if [[ $1 == old ]]; then printf '%s\n' "$OLD"; else printf '%s\n' "$NEW"; fi; }

# --- bookkeeping --------------------------------------------------------------------------------
passed=0
failed=0
ok() { passed=$((passed + 1)); printf 'ok         %s\n' "$1"; }
different() { failed=$((failed + 1)); printf 'DIFFERENT  %s%s\n' "$1" "${2:+  ($2)}"; }

# same_text NAME A B: the two files are byte-identical; if not, a unified diff goes to cmp/.
same_text() {
  local name=$1 a=$2 b=$3 d
  if cmp -s -- "$a" "$b"; then
    ok "$name"
  else
    d="$CMP/$(printf '%s' "$name" | tr -c 'A-Za-z0-9._-' '_').diff"
    diff -u -- "$a" "$b" >"$d" || true
    different "$name" "see $d"
  fi
}

# console BASE BUILDDIR > FILE: exit status, stdout and stderr of a run, with timings and the
# build's output directory replaced by placeholders. Removed: "<number> s" / "<number>s"
# (durations: render time, walk time, "[1.03 s]", progress "in 0.0s"), "= <number>/s" (ray
# rates), "peak memory <number> MB", and stderr progress lines other than the final 100% (how many
# intermediate percentages get printed depends on the wall clock).
console() {
  python3 - "$1" "$2" <<'EOF'
import re, sys
base, builddir = sys.argv[1], sys.argv[2]
def norm(text):
    text = text.replace(builddir, "<BUILD>")
    text = re.sub(r"=\s*[0-9.]+(e[+-]?[0-9]+)?/s\b", "= <rate>/s", text)
    text = re.sub(r"peak memory [0-9.]+ ?[kMG]?B\b", "peak memory <mem>", text)
    text = re.sub(r"\b[0-9]+(\.[0-9]+)?(e[+-]?[0-9]+)? ?s\b", "<t> s", text)
    return text
out = open(base + ".out", errors="replace").read()
err = open(base + ".err", errors="replace").read().replace("\r", "\n")
err = "\n".join(l for l in err.split("\n")
                if not re.match(r"\s*render: [0-9]+%", l) or "100%" in l)
rc = open(base + ".rc").read().strip()
sys.stdout.write("exit status %s\n--- stdout\n%s\n--- stderr\n%s\n" % (rc, norm(out), norm(err)))
EOF
}

# --- EXR headers ------------------------------------------------------------------------------
# header EXR > FILE: "key: value" per line, sorted, values of the keys that legitimately differ
# replaced by <ignored>. Uses OpenImageIO's Python module, else oiiotool, else iinfo.
IGNORED_HEADER_KEYS="lamina:seconds lamina:command DateTime"
if python3 -c "import OpenImageIO" 2>/dev/null; then
  HEADER_TOOL=python-oiio
elif command -v oiiotool >/dev/null; then
  HEADER_TOOL=oiiotool
elif command -v iinfo >/dev/null; then
  HEADER_TOOL=iinfo
else
  HEADER_TOOL=none
fi
header() {
  local exr=$1
  case $HEADER_TOOL in
    python-oiio)
      python3 - "$exr" "$IGNORED_HEADER_KEYS" <<'EOF'
import sys, OpenImageIO as oiio
path, ignored = sys.argv[1], sys.argv[2].split()
inp = oiio.ImageInput.open(path)
if inp is None:
    sys.exit("cannot open " + path + ": " + oiio.geterror())
spec = inp.spec()
lines = ["size: %dx%d" % (spec.width, spec.height),
         "channel list: " + ", ".join(spec.channelnames),
         "format: " + str(spec.format)]
for a in spec.extra_attribs:
    lines.append("%s: %s" % (a.name, "<ignored>" if a.name in ignored else a.value))
inp.close()
print("\n".join(sorted(lines)))
EOF
      ;;
    oiiotool | iinfo)
      local -a tool=(oiiotool --info -v)
      [[ $HEADER_TOOL == iinfo ]] && tool=(iinfo -v)
      "${tool[@]}" "$exr" | python3 -c '
import sys
ignored = sys.argv[1].split()
lines = []
for line in sys.stdin:
    # attribute lines are indented; the "Reading FILE" and "FILE : size" lines name the file
    if not line.startswith("    ") or ": " not in line:
        continue
    key, value = line.strip().split(": ", 1)
    lines.append("%s: %s" % (key, "<ignored>" if key in ignored else value))
print("\n".join(sorted(lines)))' "$IGNORED_HEADER_KEYS"
      ;;
  esac
}

# --- renders ----------------------------------------------------------------------------------
# Jobs: tag -> arguments (none of them contains a space; --seed, --threads, --cache and -o are
# added by render()).
TAGS=()
declare -A JOB=()
job() { local tag=$1; shift; TAGS+=("$tag"); JOB[$tag]="$*"; }
job cornell scenes/cornell_box/CornellBox.glb --width 64 --height 48 --spp 4
for mode in random-walk first-order table lambert; do
  job "head_$mode" scenes/head_skin/head_skin.gltf --env 0.05 --width 64 --height 48 --spp 4 \
    --subsurface "$mode"
done
job head_auto scenes/head_skin/head_skin.gltf --env 0.05 --width 64 --height 48 --spp 4 \
  --subsurface auto --tolerance 0.05
job leaves_back scenes/leaves/leaves_back.gltf --width 64 --height 48 --spp 4
for angle in 0 45; do
  for mode in random-walk lambert; do
    job "spheres_${angle}_$mode" "scenes/spheres/spheres_$angle.gltf" --width 48 --height 48 \
      --spp 4 --subsurface "$mode"
  done
done

# render BUILD THREADS TAG [CACHE [SUFFIX]]: writes BUILD/render/TAG_tTHREADS[SUFFIX].{exr,out,err,rc}
render() {
  local build=$1 threads=$2 tag=$3 cache=${4:-$WORKDIR/$1/cache} suffix=${5:-} rc=0
  local base="$WORKDIR/$build/render/${tag}_t$threads$suffix"
  local -a args
  read -ra args <<<"${JOB[$tag]}"
  "$(exe_of "$build")" render "${args[@]}" -o "$base.exr" --seed "$SEED" --threads "$threads" \
    --cache "$cache" >"$base.out" 2>"$base.err" || rc=$?
  echo "$rc" >"$base.rc"
}

# same_pixels NAME BASE_A BASE_B JSON: both renders succeeded and `lamina compare --json JSON`
# reports MAE ("mae") exactly 0.
same_pixels() {
  local name=$1 a=$2 b=$3 json=$4 rca rcb mae
  rca=$(cat "$a.rc") rcb=$(cat "$b.rc")
  if [[ $rca != 0 || $rcb != 0 ]]; then
    different "$name" "render exit status $rca / $rcb"
    return
  fi
  if ! "$OLD" compare "$a.exr" "$b.exr" --json "$json" >"$json.log" 2>&1; then
    different "$name" "lamina compare failed, see $json.log"
    return
  fi
  mae=$(python3 -c 'import json, sys; print(repr(json.load(open(sys.argv[1]))["mae"]))' "$json")
  if python3 -c 'import sys; sys.exit(0 if float(sys.argv[1]) == 0.0 else 1)' "$mae"; then
    ok "$name"
  else
    different "$name" "MAE $mae, see $json"
  fi
}

for build in old new; do
  for threads in "${THREADS[@]}"; do
    echo "compare_builds: rendering with $build, $threads thread(s)" >&2
    for tag in "${TAGS[@]}"; do render "$build" "$threads" "$tag"; done
  done
done
# The 2-thread table render above read the tables its 1-thread run built; build them again at 2
# threads in an empty cache, to check that the table walk itself does not depend on threads.
echo "compare_builds: new, table mode with a fresh cache at 2 threads" >&2
render new 2 head_table "$WORKDIR/new/cache_fresh_t2" _freshcache

printf '%s\n' "$("$OLD" --version 2>&1 || true)" >"$CMP/version.old"
printf '%s\n' "$("$NEW" --version 2>&1 || true)" >"$CMP/version.new"
same_text "version: lamina --version" "$CMP/version.old" "$CMP/version.new"

[[ $HEADER_TOOL == none ]] &&
  echo "NOTE: EXR header checks skipped: no OpenImageIO Python module, oiiotool or iinfo"
for tag in "${TAGS[@]}"; do
  for threads in "${THREADS[@]}"; do
    o="$WORKDIR/old/render/${tag}_t$threads"
    n="$WORKDIR/new/render/${tag}_t$threads"
    same_pixels "render $tag t$threads: pixels old vs new" "$o" "$n" "$CMP/${tag}_t$threads.old_vs_new.json"
    console "$o" "$WORKDIR/old" >"$CMP/${tag}_t$threads.console.old"
    console "$n" "$WORKDIR/new" >"$CMP/${tag}_t$threads.console.new"
    same_text "render $tag t$threads: console old vs new" \
      "$CMP/${tag}_t$threads.console.old" "$CMP/${tag}_t$threads.console.new"
    if [[ $HEADER_TOOL != none ]]; then
      header "$o.exr" >"$CMP/${tag}_t$threads.header.old" 2>&1 || true
      header "$n.exr" >"$CMP/${tag}_t$threads.header.new" 2>&1 || true
      same_text "render $tag t$threads: EXR header old vs new" \
        "$CMP/${tag}_t$threads.header.old" "$CMP/${tag}_t$threads.header.new"
    fi
  done
  same_pixels "render $tag: pixels new t1 vs new t2" \
    "$WORKDIR/new/render/${tag}_t1" "$WORKDIR/new/render/${tag}_t2" "$CMP/${tag}.new_t1_vs_t2.json"
done
same_pixels "render head_table: pixels new t1 vs new t2 with tables built at 2 threads" \
  "$WORKDIR/new/render/head_table_t1" "$WORKDIR/new/render/head_table_t2_freshcache" \
  "$CMP/head_table.new_t1_vs_t2_freshcache.json"

# --- brdf -------------------------------------------------------------------------------------
echo "compare_builds: brdf" >&2
for stack in scenes/materials/*.json; do
  name=$(basename "$stack" .json)
  for method in monte-carlo first-order; do
    extra=()
    [[ $method == monte-carlo ]] && extra=(--samples 20000)
    for build in old new; do
      base="$WORKDIR/$build/brdf/${name}_$method"
      rc=0
      "$(exe_of "$build")" brdf "$stack" --method "$method" "${extra[@]}" --theta-i 30 \
        --seed "$SEED" --summary "$base.json" --out "$base.csv" >"$base.out" 2>"$base.err" || rc=$?
      echo "$rc" >"$base.rc"
      touch "$base.json" "$base.csv"   # a failed run compares as empty output
      console "$base" "$WORKDIR/$build" >"$CMP/brdf_${name}_$method.console.$build"
    done
    o="$WORKDIR/old/brdf/${name}_$method"
    n="$WORKDIR/new/brdf/${name}_$method"
    same_text "brdf $name $method: CSV" "$o.csv" "$n.csv"
    same_text "brdf $name $method: summary JSON" "$o.json" "$n.json"
    same_text "brdf $name $method: console" \
      "$CMP/brdf_${name}_$method.console.old" "$CMP/brdf_${name}_$method.console.new"
  done
done

# --- batch --list -----------------------------------------------------------------------------
echo "compare_builds: batch --list" >&2
for manifest in scenes/batch/*.json; do
  name=$(basename "$manifest" .json)
  for build in old new; do
    base="$WORKDIR/$build/batch/$name"
    rc=0
    "$(exe_of "$build")" batch "$manifest" --list -o "$base-batch" >"$base.out" 2>"$base.err" || rc=$?
    echo "$rc" >"$base.rc"
    console "$base" "$WORKDIR/$build" >"$CMP/batch_$name.console.$build"
  done
  same_text "batch $name --list" "$CMP/batch_$name.console.old" "$CMP/batch_$name.console.new"
done

# --- batch runs -------------------------------------------------------------------------------
# Whole batches, small: the manifests of scenes/batch/ with 24x24 images and spp / 32 (relative
# paths made absolute so the copies can live in WORKDIR). Every output of OLD and NEW must be
# the same: the job EXRs' pixels and headers (timings ignored, the output directory replaced),
# the comparisons, jobs.json, the variant stacks and maps, and summary.csv less its seconds and
# rays_per_second columns.
echo "compare_builds: batch runs" >&2
# A batch job's lamina:command names only the output directory (replaced below) and the
# manifest's absolute paths, so it is compared too.
IGNORED_HEADER_KEYS="lamina:seconds DateTime"
small_manifest() {
  python3 - "$1" "$2" <<'EOF'
import json, os, sys
src, dst = sys.argv[1], sys.argv[2]
here = os.path.dirname(os.path.abspath(src))
m = json.load(open(src))
def absolute(v):
    if isinstance(v, dict):
        return {k: absolute(x) for k, x in v.items()}
    if isinstance(v, list):
        return [absolute(x) for x in v]
    if isinstance(v, str) and not os.path.isabs(v) and os.path.exists(os.path.join(here, v)):
        return os.path.normpath(os.path.join(here, v))
    return v
m = absolute(m)
m.setdefault("settings", {}).update({"width": 24, "height": 24})
scale = lambda n: max(1, n // 32)
m["spp"] = [scale(n) for n in m["spp"]] if isinstance(m["spp"], list) else scale(m["spp"])
for c in m.get("comparisons", []):
    for side in ("reference", "test"):
        if "spp" in c.get(side, {}):
            c[side]["spp"] = scale(c[side]["spp"])
json.dump(m, open(dst, "w"), indent=2)
EOF
}
for manifest in scenes/batch/*.json; do
  name=$(basename "$manifest" .json)
  small_manifest "$manifest" "$WORKDIR/$name.small.json"
  for build in old new; do
    base="$WORKDIR/$build/batch/run_$name"
    rc=0
    "$(exe_of "$build")" batch "$WORKDIR/$name.small.json" -o "$base" --threads 2 >"$base.out" 2>"$base.err" || rc=$?
    echo "$rc" >"$base.rc"
    console "$base" "$WORKDIR/$build" >"$CMP/batchrun_$name.console.$build"
  done
  o="$WORKDIR/old/batch/run_$name"
  n="$WORKDIR/new/batch/run_$name"
  same_text "batch $name run: console" "$CMP/batchrun_$name.console.old" "$CMP/batchrun_$name.console.new"
  for f in jobs.json comparisons.csv; do
    same_text "batch $name run: $f" "$o/$f" "$n/$f"
  done
  for build in old new; do
    cut -d, -f1-6,9- "$WORKDIR/$build/batch/run_$name/summary.csv" >"$CMP/batchrun_$name.summary.$build" 2>/dev/null || true
    (cd "$WORKDIR/$build/batch/run_$name" && find materials -type f -print0 2>/dev/null | sort -z | xargs -0 -r sha256sum) \
      >"$CMP/batchrun_$name.materials.$build" || true
  done
  same_text "batch $name run: summary.csv less timings" "$CMP/batchrun_$name.summary.old" "$CMP/batchrun_$name.summary.new"
  same_text "batch $name run: variant stacks and maps" "$CMP/batchrun_$name.materials.old" "$CMP/batchrun_$name.materials.new"
  for exr in "$o"/jobs/*.exr "$o"/diffs/*.exr; do
    [[ -e $exr ]] || continue
    rel=${exr#"$o"/}
    tag="batchrun_${name}_$(printf '%s' "$rel" | tr '/' '_')"
    echo 0 >"$CMP/$tag.a.rc"
    if [[ -e $n/$rel ]]; then echo 0 >"$CMP/$tag.b.rc"; else echo 1 >"$CMP/$tag.b.rc"; fi
    ln -sf "$exr" "$CMP/$tag.a.exr"
    ln -sf "$n/$rel" "$CMP/$tag.b.exr"
    same_pixels "batch $name run: $rel pixels" "$CMP/$tag.a" "$CMP/$tag.b" "$CMP/$tag.json"
    if [[ $HEADER_TOOL != none && $rel == jobs/* ]]; then
      header "$exr" 2>&1 | sed "s#$o#<OUT>#g" >"$CMP/$tag.header.old" || true
      header "$n/$rel" 2>&1 | sed "s#$n#<OUT>#g" >"$CMP/$tag.header.new" || true
      same_text "batch $name run: $rel header" "$CMP/$tag.header.old" "$CMP/$tag.header.new"
    fi
  done
done

echo "$passed passed, $failed failed"
[[ $failed -eq 0 ]]
