#!/usr/bin/env bash
# Configures (Release) and builds into build/. Incremental: a second run rebuilds only what
# changed. Usage: scripts/build.sh [extra cmake args]
# LAMINA_BUILD_TARGET: one target instead of all (the demo builds only `lamina`: about half the
# compile time of a fresh clone; scripts/test.sh builds the rest).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
fi
cmake --build "$BUILD_DIR" -j "$(nproc)" ${LAMINA_BUILD_TARGET:+--target "$LAMINA_BUILD_TARGET"}
