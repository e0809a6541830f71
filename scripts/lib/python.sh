# Sourced by the Python wrappers (scripts/figures.sh, scripts/tradeoff.sh): sets LAMINA_PY to an
# interpreter that has numpy and matplotlib: $LAMINA_PYTHON if set, then Debian's /usr/bin/python3
# (python3-numpy and python3-matplotlib are in scripts/setup.sh), then the python3 on PATH (a pyenv
# or venv interpreter may lack them). Returns non-zero, with a one-line message naming the caller,
# if there is none.
lamina_find_python() {
  local caller=$1 py
  for py in ${LAMINA_PYTHON:-} /usr/bin/python3 python3; do
    if command -v "$py" >/dev/null 2>&1 && "$py" -c 'import numpy, matplotlib' >/dev/null 2>&1; then
      LAMINA_PY=$py
      return 0
    fi
  done
  echo "$caller: no python3 with numpy and matplotlib found (run scripts/setup.sh, or set LAMINA_PYTHON)" >&2
  return 1
}
