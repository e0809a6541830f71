#!/usr/bin/env bash
# Installs the pinned Python tools that write the reference data of some tests (never used by
# the renderer or by the tests themselves, which read only the committed outputs):
#   scripts/mitsuba_reference.py, scripts/mitsuba_halfspace_reference.py -> tests/data/ (Mitsuba 3)
#   scripts/skin_presets.py -> scenes/materials/skin_{light,medium,dark}.json, nist_skin_rgb.csv
#     (colour-science, scipy; pip downloads the iadpython sdist itself, which needs wheel)
#   scripts/iad_reference.py -> tests/data/iad_reference.csv (iadpython, scipy)
#   scripts/iad_inversion_reference.py -> tests/data/iad_inversion_reference.csv (iadpython)
#   scripts/spectral_data.py -> materials/spectral/*_data.cpp (colour-science, prosail, scipy;
#     pip downloads the MNE-Python and SIMPA wheels itself, without installing them)
#   scripts/spectral_reference.py -> tests/data/prospect_d_reference.csv,
#     spectral_colour_reference.csv (prosail, colour-science)
# Usage: scripts/setup_references.sh, then run the script you need.
set -euo pipefail
PACKAGES=("mitsuba==3.9.1" "colour-science==0.4.7" "scipy==1.17.1" "numpy" "wheel" "iadpython==0.5.3" "prosail==2.0.5")
# Debian's own python3 refuses pip installs outside a venv (PEP 668): fall back as test.sh does.
python3 -m pip install --quiet "${PACKAGES[@]}" ||
  python3 -m pip install --quiet --break-system-packages "${PACKAGES[@]}"
