#!/usr/bin/env python3
"""Writes data/nist_skin/nist_skin_reflectance.csv: the NIST skin reflectance set, each subject's
average spectrum resampled to 400-1000 nm every 10 nm (linear interpolation of the 3-nm data).

Source: Cooksey, Allen and Tsai, "Reference data set of human skin reflectance", J. Res. NIST
122:26 (2017), DOI 10.18434/M38597: 100 subjects, inner forearm, 8 degree:hemispherical
reflectance factor, three repeats and their average per subject. A work of the US government
(NIST), not subject to copyright in the United States. The file ships in the source distribution
of the PyPI package iadpython 0.5.3 (iadpython/data/M38597.csv), which scripts/skin_presets.py
downloads (pinned) into build/skin_data/.

Usage: python3 scripts/nist_skin_spectra.py
"""
import os
import sys

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
sys.path.insert(0, os.path.join(ROOT, 'scripts'))
import skin_presets  # noqa: E402  (its nist_csv() fetches the pinned file)

OUT = os.path.join(ROOT, 'data', 'nist_skin', 'nist_skin_reflectance.csv')


def main():
    path = skin_presets.nist_csv()
    data = np.loadtxt(path, skiprows=8, delimiter=',', encoding='latin1', usecols=[0] + [4 + 4 * s for s in range(100)])
    nm = np.arange(400.0, 1001.0, 10.0)
    with open(OUT, 'w', encoding='utf-8') as f:
        f.write('# NIST skin reflectance (Cooksey, Allen, Tsai 2017, DOI 10.18434/M38597), average of 3 repeats per '
                'subject, 8 deg:hemispherical reflectance factor, resampled linearly to 10 nm; '
                'scripts/nist_skin_spectra.py\n')
        f.write('nm,' + ','.join(f'subject_{s + 1}' for s in range(100)) + '\n')
        for w in nm:
            row = [np.interp(w, data[:, 0], data[:, 1 + s]) for s in range(100)]
            f.write(f'{int(w)},' + ','.join(f'{v:.5f}' for v in row) + '\n')
    print('wrote', os.path.relpath(OUT, ROOT))


if __name__ == '__main__':
    main()
