#!/usr/bin/env python3
"""Measured skin presets: scenes/materials/skin_{light,medium,dark}.json and nist_skin_rgb.csv.

1. The NIST skin reflectance database (Cooksey, Allen, Tsai, "Reference data set of human skin
   reflectance", J. Res. NIST 122:26, 2017, DOI 10.18434/M38597: 100 subjects, inner forearm,
   250-2500 nm, 8 degree:hemispherical reflectance factor) ships inside the source distribution of
   the PyPI package iadpython 0.5.3 (iadpython/data/M38597.csv); this script downloads that
   sdist with pip (pinned) into build/skin_data/ unless it is there.
2. Each subject's average spectrum is integrated against the CIE 1931 2 degree observer under
   illuminant D65 (colour-science 0.4.7, pinned) and converted to linear Rec. 709 RGB (no
   transfer function; a perfect white reflector is (1, 1, 1)): nist_skin_rgb.csv.
3. The subjects sorted by luminance Y are split into thirds: light, medium, dark. Each preset's
   target is its third's median RGB.
4. Each preset is skin.json with four numbers fitted by Nelder-Mead (scipy 1.17.1) so that its
   total reflectance at 8 degrees (R_specular + R_diffuse of `lamina brdf`, 20000 photons, fixed
   seed: a deterministic objective) matches the target: the epidermal melanin volume fraction,
   the dermal blood volume fraction and a scale of every layer's scattering coefficient. Its top
   gets the skin roughness 0.35 (Weyrich et al. 2006). The fit and its residuals are printed;
   tests/materials/stack/test_skin_presets.cpp checks each preset against its third's spread.

Usage: scripts/skin_presets.py [LAMINA]  (default build/renderer/lamina)
"""
import copy
import csv
import glob
import json
import os
import subprocess
import sys
import tarfile
import tempfile

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
MATERIALS = os.path.join(ROOT, 'scenes', 'materials')
DATA = os.path.join(ROOT, 'build', 'skin_data')
IADPYTHON = '0.5.3'


def nist_csv():
    path = os.path.join(DATA, 'M38597.csv')
    if os.path.exists(path):
        return path
    os.makedirs(DATA, exist_ok=True)
    subprocess.run([sys.executable, '-m', 'pip', 'download', '--quiet', '--no-deps', '--no-binary', ':all:',
                    '--no-build-isolation', 'iadpython==' + IADPYTHON, '-d', DATA], check=True)
    sdist = glob.glob(os.path.join(DATA, 'iadpython-%s.tar.gz' % IADPYTHON))[0]
    with tarfile.open(sdist) as t:
        member = t.getmember('iadpython-%s/iadpython/data/M38597.csv' % IADPYTHON)
        with t.extractfile(member) as src, open(path, 'wb') as dst:
            dst.write(src.read())
    return path


def subject_rgb(path):
    import colour
    # Column 0 the wavelength, then per subject R1, R2, R3 and their average.
    data = np.loadtxt(path, skiprows=8, delimiter=',', encoding='latin1', usecols=[0] + [4 + 4 * s for s in range(100)])
    wavelength = data[:, 0]
    keep = (wavelength >= 360) & (wavelength <= 830)
    cmfs = colour.MSDS_CMFS['CIE 1931 2 Degree Standard Observer']
    d65 = colour.SDS_ILLUMINANTS['D65']
    rgbs = []
    for subject in range(100):
        # The subject's average spectrum, sampled every 3 nm: linearly resampled to 5 nm for the
        # ASTM E308 weights colour-science integrates with.
        wl5 = np.arange(360.0, 831.0, 5.0)
        r = np.interp(wl5, wavelength[keep], data[keep, 1 + subject])
        sd = colour.SpectralDistribution(dict(zip(wl5, r)))
        xyz = colour.sd_to_XYZ(sd, cmfs, d65) / 100.0
        rgb = colour.XYZ_to_RGB(xyz, colour.RGB_COLOURSPACES['sRGB'], apply_cctf_encoding=False)
        rgbs.append((subject + 1, float(xyz[1]), *[float(c) for c in rgb]))
    return rgbs


def reflectance(lamina, stack):
    with tempfile.NamedTemporaryFile('w', suffix='.json', delete=False) as f:
        json.dump(stack, f)
        name = f.name
    try:
        out = subprocess.run([lamina, 'brdf', name, '--theta-i', '8', '--samples', '20000', '--seed', '5'],
                             capture_output=True, text=True, check=True).stdout
    finally:
        os.unlink(name)
    d = json.loads(out)
    return np.array(d['R_specular']) + np.array(d['R_diffuse'])


def variant(base, melanin, blood, scattering, flesh):
    s = copy.deepcopy(base)
    s['below']['lambert'] = [round(min(1.0, a * flesh), 4) for a in s['below']['lambert']]
    epi, derm = s['layers'][0]['components'], s['layers'][1]['components']
    epi[0]['fraction'], epi[1]['fraction'] = melanin, 1.0 - melanin
    derm[0]['fraction'], derm[1]['fraction'] = blood, 1.0 - blood
    for layer in s['layers']:
        for c in layer['components']:
            c['sigma_s'] = [round(x * scattering, 4) for x in c['sigma_s']]
    return s


def main():
    from scipy.optimize import minimize
    lamina = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, 'build', 'renderer', 'lamina')
    rgbs = subject_rgb(nist_csv())
    with open(os.path.join(MATERIALS, 'nist_skin_rgb.csv'), 'w', newline='') as f:
        f.write('# NIST skin reflectance (DOI 10.18434/M38597) per subject: CIE 1931 2 deg, D65, linear Rec. 709; scripts/skin_presets.py\n')
        w = csv.writer(f)
        w.writerow(['subject', 'Y', 'R', 'G', 'B'])
        for row in rgbs:
            w.writerow([row[0]] + ['%.5f' % x for x in row[1:]])
    by_y = sorted(rgbs, key=lambda r: -r[1])
    thirds = {'light': by_y[:33], 'medium': by_y[33:67], 'dark': by_y[67:]}
    base = json.load(open(os.path.join(MATERIALS, 'skin.json')))
    for name, group in thirds.items():
        target = np.median(np.array([r[2:] for r in group]), axis=0)

        def loss(x):
            melanin, blood, scattering, flesh = np.exp(x)
            if melanin >= 0.9 or blood >= 0.5 or flesh > 1.25:
                return 1e3
            r = reflectance(lamina, variant(base, melanin, blood, scattering, flesh))
            return float(np.sum(((r - target) / target) ** 2))

        # log-parameters; the initial simplex spans a factor 2 in each (scipy's default step of
        # 0.00025 for a zero entry, log(1), would leave the scattering scale where it starts).
        x0 = np.log([0.02, 0.01, 2.0, 1.1])
        simplex = np.array([x0] + [x0 + 0.5 * np.eye(4)[i] * (0.3 if i == 3 else 1.0) for i in range(4)])
        fit = minimize(loss, x0, method='Nelder-Mead',
                       options={'xatol': 0.02, 'fatol': 1e-5, 'maxfev': 110, 'initial_simplex': simplex})
        melanin, blood, scattering, flesh = np.exp(fit.x)
        stack = variant(base, round(float(melanin), 5), round(float(blood), 5), float(scattering), float(flesh))
        stack['name'] = 'skin_' + name
        r = reflectance(lamina, stack)
        print('%-6s target %s fit %s (melanin %.4f, blood %.4f, scattering x%.3f, flesh x%.3f; %d evaluations)' % (
            name, np.round(target, 4), np.round(r, 4), melanin, blood, scattering, flesh, fit.nfev))
        with open(os.path.join(MATERIALS, 'skin_%s.json' % name), 'w') as f:
            json.dump(stack, f, indent=2)
            f.write('\n')


if __name__ == '__main__':
    main()
