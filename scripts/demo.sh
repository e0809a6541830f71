#!/usr/bin/env bash
# Installs what is missing, builds, and renders the default scenes into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
mkdir -p out
echo "demo: built $("$BUILD_DIR"/renderer/lamina --version)"
