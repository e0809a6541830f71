#!/usr/bin/env python3
"""Fits every subject of the NIST skin set (data/nist_skin/nist_skin_reflectance.csv) with
`lamina fit --spectrum` and five chromophore parameters of scenes/spectral/skin_spectral.json
(epidermal melanin and its eumelanin share, dermal blood and its oxygen saturation, the dermis'
reduced scattering at 500 nm), 400-1000 nm, and reports each subject's spectral RMSE and the
colour difference CIEDE2000 (D65, colour-science 0.4.7) between the measured and the modelled
spectrum's colour: a CSV (default build/nist_skin_fit.csv) and the medians and worst cases on
stdout. docs/spectral.md, "Fitting a measured skin spectrum".

With --plot PNG it fits only the best, the median and the worst subject by RMSE of an existing
table (--table, default docs/nist_skin_fit.csv) and plots their measured against their modelled
spectra (matplotlib).

Usage: python3 scripts/nist_skin_fit.py [--lamina build/renderer/lamina] [--subjects 1,2,...]
                                        [--quadrature-points 8] [--out build/nist_skin_fit.csv]
       python3 scripts/nist_skin_fit.py --plot docs/images/nist_skin_spectra.png [--table docs/nist_skin_fit.csv]
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
PARAMS = ['layers[0].chromophores.melanin=0:0.5', 'layers[0].chromophores.eumelanin=0:1',
          'layers[1].chromophores.blood=0:0.1', 'layers[1].chromophores.oxygenation=0:1',
          'layers[1].chromophores.scattering.reduced_500=0.5:10']


def delta_e(rgb_a, rgb_b):
    warnings.simplefilter('ignore')
    import colour
    space = colour.RGB_COLOURSPACES['sRGB']
    lab = [colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.array(c), space, apply_cctf_decoding=False), space.whitepoint)
           for c in (rgb_a, rgb_b)]
    return float(colour.delta_E(lab[0], lab[1], method='CIE 2000'))


def fit(lamina, subject, points):
    with tempfile.NamedTemporaryFile(suffix='.json', delete=False) as f:
        summary = f.name
    cmd = [lamina, 'fit', os.path.join(ROOT, 'scenes', 'spectral', 'skin_spectral.json'), '--spectrum',
           os.path.join(ROOT, 'data', 'nist_skin', 'nist_skin_reflectance.csv'), '--spectrum-column',
           f'subject_{subject}', '--quadrature-points', str(points), '--summary', summary]
    for p in PARAMS:
        cmd += ['--param', p]
    t0 = os.times()
    subprocess.run(cmd, check=True)
    t1 = os.times()
    with open(summary) as f:
        d = json.load(f)
    os.unlink(summary)
    d['cpu_seconds'] = (t1.children_user + t1.children_system) - (t0.children_user + t0.children_system)
    return d


def best_median_worst(table):
    """The subjects of the lowest, the median (the lower middle of an even count) and the highest RMSE."""
    with open(table) as f:
        rows = sorted(((float(r['rmse']), int(r['subject'])) for r in csv.DictReader(f)))
    return [('best', rows[0]), ('median', rows[(len(rows) - 1) // 2]), ('worst', rows[-1])]


def plot(lamina, table, points, out):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    picks = best_median_worst(table)
    fig, axes = plt.subplots(1, len(picks), figsize=(4.2 * len(picks), 3.4), sharey=True)
    for ax, (label, (rmse, subject)) in zip(axes, picks):
        d = fit(lamina, subject, points)
        de = delta_e(d['measured_rec709'], d['modelled_rec709'])
        ax.plot(d['wavelength_nm'], d['measured'], 'o', ms=3, color='0.2', label='measured (NIST)')
        ax.plot(d['wavelength_nm'], d['modelled'], '-', color='tab:red', label='modelled (adding-doubling)')
        ax.set_title(f'{label}: subject {subject}\nRMSE {d["rmse"]:.4f}, CIEDE2000 {de:.2f}', fontsize=9)
        ax.set_xlabel('wavelength (nm)')
        ax.grid(alpha=0.3)
        print(f'{label}: subject {subject}, RMSE {d["rmse"]:.4f} (table {rmse:.4f}), CIEDE2000 {de:.2f}', flush=True)
    axes[0].set_ylabel('reflectance (8 degrees)')
    axes[0].legend(fontsize=8, loc='upper left')
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(os.path.relpath(out, ROOT))
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--lamina', default=os.path.join(ROOT, 'build', 'renderer', 'lamina'))
    parser.add_argument('--subjects', default=','.join(str(s) for s in range(1, 101)))
    parser.add_argument('--quadrature-points', type=int, default=8)
    parser.add_argument('--out', default=os.path.join(ROOT, 'build', 'nist_skin_fit.csv'))
    parser.add_argument('--plot', help='PNG: plot the best, median and worst subject of --table instead')
    parser.add_argument('--table', default=os.path.join(ROOT, 'docs', 'nist_skin_fit.csv'))
    args = parser.parse_args()
    if args.plot:
        return plot(args.lamina, args.table, args.quadrature_points, args.plot)
    rows = []
    for s in [int(x) for x in args.subjects.split(',')]:
        d = fit(args.lamina, s, args.quadrature_points)
        de = delta_e(d['measured_rec709'], d['modelled_rec709'])
        rows.append([s, d['rmse'], de, d['evaluations'], d['cpu_seconds']] + [v for v in d['parameters'].values()])
        print(f'subject {s}: RMSE {d["rmse"]:.4f}, CIEDE2000 {de:.2f}, {d["evaluations"]} spectra, '
              f'{d["cpu_seconds"]:.1f} s CPU', flush=True)
    with open(args.out, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['subject', 'rmse', 'ciede2000', 'evaluations', 'cpu_seconds'] + [p.split('=')[0] for p in PARAMS])
        w.writerows(rows)
    a = np.array([r[1:5] for r in rows])
    print(f'{len(rows)} subjects: median RMSE {np.median(a[:, 0]):.4f} (worst {a[:, 0].max():.4f}, subject '
          f'{rows[int(a[:, 0].argmax())][0]}), median CIEDE2000 {np.median(a[:, 1]):.2f} (worst {a[:, 1].max():.2f}), '
          f'median {np.median(a[:, 3]):.2f} s CPU per subject; {os.path.relpath(args.out, ROOT)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
