#!/usr/bin/env bash
# The speed-accuracy report (scripts/tradeoff.py; arguments are passed on, e.g. --quick,
# --lamina PATH, --out DIR): every --subsurface mode at increasing spp on the spheres, the head
# with skin and the leaf, RMSE against a high-sample random-walk reference by `lamina compare`,
# into out/tradeoff/tradeoff.csv and tradeoff.png. The interpreter (one with numpy and
# matplotlib) is chosen by scripts/lib/python.sh.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
. "$here/lib/python.sh"
lamina_find_python tradeoff.sh || exit 1
exec "$LAMINA_PY" "$here/tradeoff.py" "$@"
