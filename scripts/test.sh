#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test. Exits non-zero on any failure.
# Usage: scripts/test.sh [--sanitize]
#   --sanitize: build with AddressSanitizer and UndefinedBehaviorSanitizer into build-sanitize/
#               (LAMINA_BUILD_DIR overrides) and run the whole suite there; any memory error,
#               leak or undefined behaviour fails the test that triggers it.
set -euo pipefail
cd "$(dirname "$0")/.."
SANITIZE=0
for arg in "$@"; do
  case $arg in
    --sanitize) SANITIZE=1 ;;
    *) echo "usage: scripts/test.sh [--sanitize]" >&2; exit 2 ;;
  esac
done
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
# The Python package's tests (tests/python, examples/: ctest python_*) need numpy, matplotlib
# and pytest: the pinned python/requirements.txt, installed when one is missing.
if ! python3 -c "import nanobind, numpy, matplotlib, pytest" >/dev/null 2>&1; then
  echo "test: installing the Python package's pinned requirements (python/requirements.txt)"
  python3 -m pip install --quiet -r python/requirements.txt ||
    python3 -m pip install --quiet --break-system-packages -r python/requirements.txt
fi
# The Slurm batch driver's test (tests/renderer/cli/test_batch_slurm.cpp) starts a private local cluster
# (scripts/lib/local_slurm.sh): it needs slurm-wlm and munge (setup.sh installs them) and root.
# It fails (never skips silently) without them; LAMINA_SKIP_SLURM=1 skips it.
if [ "$SANITIZE" = 1 ]; then
  export LAMINA_BUILD_DIR=${LAMINA_BUILD_DIR:-build-sanitize}
  # Leak reports of the third-party libraries that are not ours to fix: scripts/lsan.supp.
  export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1}
  export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/scripts/lsan.supp:print_suppressions=0}
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
  scripts/build.sh -DLAMINA_SANITIZE=ON -DLAMINA_BUILD_BENCH=OFF
  TIMEOUT=1800  # instrumented code runs 2-4x slower
else
  scripts/build.sh
  TIMEOUT=600
fi
BUILD_DIR=${LAMINA_BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout "$TIMEOUT"
