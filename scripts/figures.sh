#!/usr/bin/env bash
# Regenerates the paper's figures into out/figures/ (scripts/figures.py; arguments are passed on,
# e.g. --quick, --lamina PATH, --out DIR). Python draws plots only; every number comes from
# `lamina brdf`. The interpreter (one with numpy and matplotlib) is chosen by scripts/lib/python.sh.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
. "$here/lib/python.sh"
lamina_find_python figures.sh || exit 1
exec "$LAMINA_PY" "$here/figures.py" "$@"
