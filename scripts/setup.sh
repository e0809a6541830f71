#!/usr/bin/env bash
# Installs the Debian packages Lamina needs, only those missing. Run as root (or with sudo).
# Idempotent: does nothing (and needs no network) when everything is installed. Also the pinned
# pyoidn wheel (pip), whose Open Image Denoise library `lamina denoise` loads.
# Usage: scripts/setup.sh [--render-only] [--list]
#   --render-only  only what building and running `lamina` needs: no test, benchmark, figure or
#                  cluster (Slurm) packages (docs/README.md, "Installing")
#   --list         print the missing packages, one a line, and install nothing (needs no root)
set -euo pipefail

render_only=0
list_only=0
for arg in "$@"; do
  case $arg in
    --render-only) render_only=1 ;;
    --list) list_only=1 ;;
    *) echo "setup: unknown option '$arg' (expected --render-only, --list)" >&2; exit 2 ;;
  esac
done

# What building and running lamina needs.
render_packages=(
  build-essential cmake ninja-build pkg-config
  libembree-dev            # Embree 3: ray tracing kernels
  libopenexr-dev           # EXR reading and writing
  libpng-dev               # PNG writing (previews, 16-bit data maps)
  libstb-dev               # stb_image: reading PNG, JPEG, HDR and the other integer formats
  libfreetype-dev          # text in contact sheets and false-colour legends
  openimageio-tools        # oiiotool for scripts (demo mosaics, scene maps); never linked
  fonts-dejavu-core        # legend text in `lamina compare --png` (a bitmap font is the fallback)
  libtinygltf-dev          # glTF 2.0 loader (with stb_image and nlohmann-json)
  nlohmann-json3-dev       # material files and manifests
  libcli11-dev             # command-line parsing
  libglm-dev libtbb-dev
  libnlopt-dev             # lamina fit's optimiser (materials/fit/stack_fit)
  python3 python3-pip      # finds and installs Open Image Denoise (below) for lamina denoise
)
# The rest: tests, benchmarks, figures, the local Slurm cluster of the batch tests.
other_packages=(
  libgtest-dev libbenchmark-dev
  python3-numpy python3-matplotlib  # figures and reports only, never the render path
  slurm-wlm munge          # a private local Slurm cluster for scripts/batch_slurm.sh's test (scripts/lib/local_slurm.sh)
)

packages=("${render_packages[@]}")
if [ "$render_only" -eq 0 ]; then packages+=("${other_packages[@]}"); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "$list_only" -eq 1 ]; then
  if [ ${#missing[@]} -gt 0 ]; then printf '%s\n' "${missing[@]}"; fi
  exit 0
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Intel Open Image Denoise for `lamina denoise` (a post-process, never the render path): Debian
# bookworm has no package, so the library comes from the pinned pyoidn wheel, which ships it
# (renderer/image/denoise.h loads it at run time; CMake records where python3 finds it).
# Checked without importing pyoidn (its Python side needs cffi, which Lamina does not use).
PYOIDN_VERSION=2.5.1.0
if ! python3 -c "import importlib.metadata as m, sys; sys.exit(m.version('pyoidn') != '${PYOIDN_VERSION}')" >/dev/null 2>&1; then
  echo "setup: installing pyoidn==${PYOIDN_VERSION} (Open Image Denoise for lamina denoise)"
  # Debian's own python3 refuses pip installs outside a venv (PEP 668): --break-system-packages there.
  python3 -m pip install --quiet --no-deps "pyoidn==${PYOIDN_VERSION}" ||
    python3 -m pip install --quiet --no-deps --break-system-packages "pyoidn==${PYOIDN_VERSION}"
fi

# nanobind, with which CMake builds the Python package (python/, docs/python.md; the option
# LAMINA_BUILD_PYTHON, on by default): pinned as in pyproject.toml. A pure-Python wheel; the
# package's tests need more (scripts/test.sh).
NANOBIND_VERSION=3.1.0
if ! python3 -c "import importlib.metadata as m, sys; sys.exit(m.version('nanobind') != '${NANOBIND_VERSION}')" >/dev/null 2>&1; then
  echo "setup: installing nanobind==${NANOBIND_VERSION} (builds the Python package)"
  python3 -m pip install --quiet "nanobind==${NANOBIND_VERSION}" ||
    python3 -m pip install --quiet --break-system-packages "nanobind==${NANOBIND_VERSION}"
fi
