#!/usr/bin/env bash
# Regenerates the paper's figures into out/figures/ (scripts/figures.py; arguments are passed on,
# e.g. --quick, --lamina PATH, --out DIR). Python draws plots only; every number comes from
# `lamina brdf`. Chooses an interpreter that has numpy and matplotlib: $LAMINA_PYTHON if set, then
# Debian's /usr/bin/python3 (python3-numpy and python3-matplotlib are in scripts/setup.sh), then
# the python3 on PATH (a pyenv or venv interpreter may lack them).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
for py in ${LAMINA_PYTHON:-} /usr/bin/python3 python3; do
  if command -v "$py" >/dev/null 2>&1 && "$py" -c 'import numpy, matplotlib' >/dev/null 2>&1; then
    exec "$py" "$here/figures.py" "$@"
  fi
done
echo "figures.sh: no python3 with numpy and matplotlib found (run scripts/setup.sh, or set LAMINA_PYTHON)" >&2
exit 1
