#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test. Exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# The Ray batch driver's test (tests/renderer/cli/test_batch_ray.cpp) needs the Python package ray: a
# pinned version, installed here rather than in setup.sh so building and rendering never wait
# for it. It fails (never skips silently) when ray is missing; LAMINA_SKIP_RAY=1 skips it.
RAY_VERSION=2.60.0
if [ "${LAMINA_SKIP_RAY:-0}" != 1 ] && ! python3 -c "import ray" >/dev/null 2>&1; then
  echo "test: installing ray==${RAY_VERSION} for the Ray batch driver test"
  # Debian's own python3 refuses pip installs outside a venv (PEP 668): fall back to
  # --break-system-packages there (pip is from python3-pip, see scripts/setup.sh).
  python3 -m pip install --quiet "ray==${RAY_VERSION}" ||
    python3 -m pip install --quiet --break-system-packages "ray==${RAY_VERSION}"
fi
# The Slurm batch driver's test (tests/renderer/cli/test_batch_slurm.cpp) starts a private local cluster
# (scripts/lib/local_slurm.sh): it needs slurm-wlm and munge (setup.sh installs them) and root.
# It fails (never skips silently) without them; LAMINA_SKIP_SLURM=1 skips it.
scripts/build.sh
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 600
