#!/usr/bin/env python3
"""Writes the reference data of tests/materials/spectral/ from independent implementations:
  tests/data/prospect_d_reference.csv   PROSPECT-D leaf reflectance and transmittance, 400-2500 nm
      every 1 nm, by the PyPI package prosail 2.0.5 (prosail.run_prospect, version "D") for leaf
      parameter sets spanning the ANGERS leaves (Feret et al. 2008, Remote Sens. Environ. 112:3030:
      N 1.0-3.0, chlorophyll 0.8-106 ug/cm2, carotenoids 0-25 ug/cm2, water 0.004-0.034 cm, dry
      matter 0.002-0.033 g/cm2), anthocyanins and brown pigments added;
  tests/data/spectral_colour_reference.csv   CIE 1931 XYZ (D65, Y of a perfect reflector 1) and
      linear Rec. 709 of analytic spectra on the 5-nm colour grid by colour-science 0.4.7
      (colour.sd_to_XYZ, method "Integration"; colour.XYZ_to_RGB, sRGB without its transfer curve).
Both packages are pinned in scripts/setup_references.sh.

Usage: python3 scripts/spectral_reference.py          writes both files
       python3 scripts/spectral_reference.py --check  exits 1 if a committed file differs from
                                                      what the packages give now (ctest
                                                      spectral_reference)
"""
import argparse
import importlib.metadata
import io
import math
import os
import sys
import warnings

import numpy as np

from spectral_data import write_or_check

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
DATA = os.path.join(ROOT, 'tests', 'data')
PINS = {'prosail': '2.0.5', 'colour-science': '0.4.7'}

# name, N, chlorophyll, carotenoids, anthocyanins, brown, water (cm), dry matter (g/cm2)
LEAVES = [
    ('mature_green', 1.5, 40.0, 8.0, 0.0, 0.0, 0.010, 0.009),
    ('thin_pale', 1.2, 5.0, 1.0, 0.5, 0.0, 0.005, 0.002),
    ('thick_dark', 2.5, 100.0, 25.0, 5.0, 0.5, 0.034, 0.030),
    ('one_plate_red', 1.0, 20.0, 4.0, 10.0, 1.0, 0.020, 0.012),
    ('senescent', 3.0, 0.8, 2.0, 1.0, 2.0, 0.004, 0.033),
]

# Analytic spectra for the colour test: kind, a, b (the test rebuilds each from these).
#   constant: value a;  gaussian: exp(-((nm - a) / b)^2 / 2);  ramp: (nm - 360) / 420
COLOURS = [
    ('constant', 1.0, 0.0), ('constant', 0.18, 0.0),
    ('gaussian', 450.0, 20.0), ('gaussian', 550.0, 30.0), ('gaussian', 610.0, 25.0), ('ramp', 0.0, 0.0),
]


def check_pins():
    for package, version in PINS.items():
        have = importlib.metadata.version(package)
        if have != version:
            sys.exit(f'spectral_reference: {package} {have} is installed, pinned {version} (scripts/setup_references.sh)')


def spectrum_of(kind, a, b, nm):
    if kind == 'constant':
        return np.full_like(nm, a)
    if kind == 'gaussian':
        return np.exp(-0.5 * ((nm - a) / b) ** 2)
    return (nm - 360.0) / 420.0


def prospect_csv():
    import prosail
    out = io.StringIO()
    out.write('# PROSPECT-D by prosail 2.0.5 (prosail.run_prospect); scripts/spectral_reference.py\n')
    out.write('# leaf: ' + '; '.join(f'{name} N={n} cab={cab} car={car} ant={ant} brown={brown} cw={cw} cm={cm}'
                                    for name, n, cab, car, ant, brown, cw, cm in LEAVES) + '\n')
    columns = []
    for name, n, cab, car, ant, brown, cw, cm in LEAVES:
        wl, r, t = prosail.run_prospect(n, cab, car, brown, cw, cm, ant=ant, prospect_version='D')
        columns += [r, t]
    out.write('nm,' + ','.join(f'R_{leaf[0]},T_{leaf[0]}' for leaf in LEAVES) + '\n')
    for i, w in enumerate(wl):
        out.write(f'{int(w)},' + ','.join(f'{c[i]:.10f}' for c in columns) + '\n')
    return out.getvalue()


def colour_csv():
    warnings.simplefilter('ignore')
    import colour
    nm = np.arange(360.0, 781.0, 5.0)
    shape = colour.SpectralShape(360, 780, 5)
    cmfs = colour.MSDS_CMFS['CIE 1931 2 Degree Standard Observer'].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS['D65'].copy().align(shape)
    out = io.StringIO()
    out.write('# CIE 1931 2 deg under D65 by colour-science 0.4.7 (sd_to_XYZ Integration, XYZ_to_RGB sRGB linear); '
              'scripts/spectral_reference.py\n')
    out.write('kind,a,b,X,Y,Z,R,G,B\n')
    srgb = colour.RGB_COLOURSPACES['sRGB']
    for kind, a, b in COLOURS:
        sd = colour.SpectralDistribution(dict(zip(nm, spectrum_of(kind, a, b, nm))))
        xyz = colour.sd_to_XYZ(sd, cmfs, d65, method='Integration') / 100.0
        rgb = colour.XYZ_to_RGB(xyz, srgb, apply_cctf_encoding=False)
        out.write(f'{kind},{a},{b},' + ','.join(f'{v:.10f}' for v in list(xyz) + list(rgb)) + '\n')
    return out.getvalue()


FILES = {'prospect_d_reference.csv': prospect_csv, 'spectral_colour_reference.csv': colour_csv}


def numbers(text):
    rows = [line.split(',') for line in text.splitlines() if line and not line.startswith('#')]
    return rows[0], rows[1:]


def same(committed, fresh):
    """Same header, same labels, numbers within 1e-9 (last-digit changes of the libraries)."""
    (h1, r1), (h2, r2) = numbers(committed), numbers(fresh)
    if h1 != h2 or len(r1) != len(r2):
        return False
    for a, b in zip(r1, r2):
        for x, y in zip(a, b):
            try:
                if not math.isclose(float(x), float(y), abs_tol=1e-9):
                    return False
            except ValueError:
                if x != y:
                    return False
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--check', action='store_true', help='compare with the committed files instead of writing')
    args = parser.parse_args()
    check_pins()
    if write_or_check(FILES, DATA, args.check, same):
        return 1
    if args.check:
        print(f'spectral_reference: {len(FILES)} reference files match prosail and colour-science')
    return 0


if __name__ == '__main__':
    sys.exit(main())
