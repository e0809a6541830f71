#!/usr/bin/env python3
"""Skin-tone presets from the NIST fits: scenes/spectral/skin_tone_{1..7}.json, skin_tones.csv,
and the figures of docs/skin_tones.md.

1. docs/nist_skin_fit.csv holds the five fitted parameters of each of the 100 NIST subjects
   (scripts/nist_skin_fit.py: epidermal melanin and its eumelanin share, dermal blood, its oxygen
   saturation, the dermis' reduced scattering at 500 nm). The tones differ in melanin alone, so
   that they are ordered by construction: a darker tone absorbs more at every wavelength and
   nothing else changes. The eumelanin share and the dermis (blood, oxygen saturation, reduced
   scattering) are the medians of all 100 subjects' fitted values, the same in every tone. The
   subjects are ranked by fitted melanin; four measured tones stand for the subjects around the
   5th, 50th, 85th and 97th percentile of that rank (9 subjects each, fewer at the end), their
   melanin the median of those subjects' fitted melanin (so it rises with the percentile).
   Per-tone dermis values (the medians of each tone's subjects) did not keep the order: on the
   fits of docs/nist_skin_fit.csv the subjects around the 5th percentile carry more blood than
   those around the 50th, whose tone then reflected more green than the lighter one.
2. The NIST set's darkest subjects (fitted melanin up to 0.11) are lighter than Fitzpatrick type VI
   skin: three further tones keep everything but melanin and raise the melanin volume fraction to
   0.15, 0.25 and 0.43, the top of Jacques' (2013) range for darkly pigmented epidermis. They are
   the model's extrapolation, not measurements.
3. Each preset is scenes/spectral/skin_spectral.json with those values; the bloodless tissue
   (baseline) fills what melanin (epidermis) or blood and water (dermis) leave, so the volume
   fractions sum to 1 (the fits held the baselines fixed, which the reader would reject for the
   darker subjects).
4. Per preset: its reflectance spectrum at 8 degrees (`lamina brdf --method adding-doubling
   --wavelengths 360:1000:5`), its colour under D65 from that spectrum, and the RGB mode's total
   reflectance (`lamina brdf --method adding-doubling` on the same file, the chromophores projected
   per channel, materials/spectral/chromophores.h); a sphere rendered in the RGB mode
   (`lamina render scenes/spheres/spheres_45.gltf --stack FILE --subsurface table`); the figures
   docs/images/skin_tones_spectra.png and docs/images/skin_tones_swatches.png; the table of
   docs/skin_tones.md printed (Markdown) on stdout.

Usage: scripts/skin_tones.py [--lamina build/renderer/lamina] [--no-render]
Needs numpy and matplotlib (scripts/setup.sh); colour differences need colour-science
(scripts/setup_references.sh) and are left out without it.
"""
import argparse
import copy
import csv
import json
import os
import subprocess
import tempfile

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
SPECTRAL = os.path.join(ROOT, 'scenes', 'spectral')
IMAGES = os.path.join(ROOT, 'docs', 'images')
PERCENTILES = [5, 50, 85, 97]
EXTRAPOLATED_MELANIN = [0.15, 0.25, 0.43]
WINDOW = 4  # subjects either side of the percentile's rank
KEYS = ['layers[0].chromophores.melanin', 'layers[0].chromophores.eumelanin', 'layers[1].chromophores.blood',
        'layers[1].chromophores.oxygenation', 'layers[1].chromophores.scattering.reduced_500']
SHORT = ['melanin', 'eumelanin', 'blood', 'oxygenation', 'reduced_500']


def read_fits():
    with open(os.path.join(ROOT, 'docs', 'nist_skin_fit.csv')) as f:
        return [{'subject': int(r['subject']), **{s: float(r[k]) for s, k in zip(SHORT, KEYS)}} for r in csv.DictReader(f)]


def read_nist():
    rows = [line for line in open(os.path.join(ROOT, 'data', 'nist_skin', 'nist_skin_reflectance.csv')) if not line.startswith('#')]
    header = rows[0].strip().split(',')
    data = np.array([[float(x) for x in line.split(',')] for line in rows[1:]])
    return data[:, 0], {int(h.split('_')[1]): data[:, i] for i, h in enumerate(header) if h.startswith('subject_')}


def presets(fits):
    shared = {s: float(np.median([r[s] for r in fits])) for s in ('blood', 'oxygenation', 'reduced_500')}
    ranked = sorted(fits, key=lambda r: r['melanin'])
    out = []
    eu = pheo = 0.0  # volume fractions of eumelanin and pheomelanin: never less than the lighter tone's
    for p in PERCENTILES:
        k = int(round(p / 100.0 * (len(ranked) - 1)))
        window = ranked[max(0, k - WINDOW):min(len(ranked), k + WINDOW + 1)]
        eu = max(eu, float(np.median([r['melanin'] * r['eumelanin'] for r in window])))
        pheo = max(pheo, float(np.median([r['melanin'] * (1.0 - r['eumelanin']) for r in window])))
        out.append({'source': 'NIST, melanin percentile %d' % p, 'subjects': sorted(r['subject'] for r in window),
                    'melanin': eu + pheo, 'eumelanin': eu / (eu + pheo), **shared})
    for m in EXTRAPOLATED_MELANIN:
        out.append({**out[len(PERCENTILES) - 1], 'melanin': m, 'subjects': [], 'source': 'extrapolated: melanin raised to %g' % m})
    return out


def stack_of(preset):
    base = json.load(open(os.path.join(SPECTRAL, 'skin_spectral.json')))
    s = copy.deepcopy(base)
    epi, derm = s['layers'][0]['chromophores'], s['layers'][1]['chromophores']
    r = lambda x: round(x, 5)
    epi['melanin'], epi['eumelanin'] = r(preset['melanin']), r(preset['eumelanin'])
    epi['baseline'] = r(1.0 - epi['melanin'])
    derm['blood'], derm['oxygenation'] = r(preset['blood']), r(preset['oxygenation'])
    derm['baseline'] = r(1.0 - derm['water'] - derm['blood'])
    derm['scattering']['reduced_500'] = r(preset['reduced_500'])
    return s


def brdf(lamina, path, *extra):
    with tempfile.NamedTemporaryFile(suffix='.json', delete=False) as f:
        summary = f.name
    try:
        subprocess.run([lamina, 'brdf', path, '--theta-i', '8', '--method', 'adding-doubling', *extra, '--summary', summary],
                       check=True, capture_output=True)
        return json.load(open(summary))
    finally:
        os.unlink(summary)


def encode(rgb):
    rgb = np.clip(np.asarray(rgb, float), 0.0, 1.0)
    return np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)


def delta_e(a, b):
    try:
        import colour
    except ImportError:
        return None
    lab = [colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.asarray(x), colour.RGB_COLOURSPACES['sRGB'], apply_cctf_decoding=False))
           for x in (a, b)]
    return float(colour.delta_E(lab[0], lab[1], method='CIE 2000'))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--lamina', default=os.path.join(ROOT, 'build', 'renderer', 'lamina'))
    ap.add_argument('--no-render', action='store_true', help='skip the spheres (the swatch figure then shows flat patches)')
    args = ap.parse_args()
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    nm_nist, nist = read_nist()
    tones = presets(read_fits())
    table = []
    with open(os.path.join(SPECTRAL, 'skin_tones.csv'), 'w', newline='') as f:
        f.write('# Skin-tone presets (scripts/skin_tones.py): the fitted parameters of NIST subjects (docs/nist_skin_fit.csv) or extrapolated\n')
        w = csv.writer(f)
        w.writerow(['preset'] + SHORT + ['subjects', 'source'])
        for i, t in enumerate(tones, 1):
            name = 'skin_tone_%d' % i
            path = os.path.join(SPECTRAL, name + '.json')
            stack = stack_of(t)
            stack['name'] = name
            with open(path, 'w') as g:
                json.dump(stack, g, indent=2)
                g.write('\n')
            c = stack['layers'][0]['chromophores'], stack['layers'][1]['chromophores']
            w.writerow([name, c[0]['melanin'], c[0]['eumelanin'], c[1]['blood'], c[1]['oxygenation'],
                        c[1]['scattering']['reduced_500'], ' '.join(map(str, t['subjects'])), t['source']])
            spectral = brdf(args.lamina, path, '--wavelengths', '360:1000:5')
            rgb = brdf(args.lamina, path)
            t.update(name=name, path=path, stack=stack, nm=np.array(spectral['wavelength_nm']),
                     R=np.array(spectral['R_specular']) + np.array(spectral['R_diffuse']),
                     spectral_rgb=np.array(spectral['R_rec709']),
                     rgb=np.array(rgb['R_specular']) + np.array(rgb['R_diffuse']))

    # The spectra, each with the NIST subjects it stands for (or the darkest ones, lighter).
    fig, axes = plt.subplots(2, 4, figsize=(13, 6), sharex=True, sharey=True)
    darkest = tones[len(PERCENTILES) - 1]['subjects']
    for ax, t in zip(axes.flat, tones):
        subjects = t['subjects'] or darkest
        for k, s in enumerate(subjects):
            ax.plot(nm_nist, nist[s], color='0.6', lw=0.8, label=('NIST subjects' if t['subjects'] else 'darkest NIST subjects') if k == 0 else None)
        keep = t['nm'] >= 400
        ax.plot(t['nm'][keep], t['R'][keep], color=encode(t['spectral_rgb']) * 0.8, lw=2.2, label='preset')
        ax.set_title('%s: melanin %.3g' % (t['name'], t['stack']['layers'][0]['chromophores']['melanin']), fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc='upper left')
    axes.flat[-1].axis('off')
    for ax in axes[-1]:
        ax.set_xlabel('wavelength (nm)')
    for ax in axes[:, 0]:
        ax.set_ylabel('reflectance, 8 degrees')
    fig.suptitle('Skin-tone presets: modelled reflectance (adding-doubling) and the NIST subjects (Cooksey et al. 2017)', fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(IMAGES, 'skin_tones_spectra.png'), dpi=90)

    # Swatches: the sphere in the RGB mode above, the spectrum's colour and the RGB mode's below.
    fig, axes = plt.subplots(2, len(tones), figsize=(1.6 * len(tones), 3.4))
    for k, t in enumerate(tones):
        if not args.no_render:
            out = os.path.join(tempfile.gettempdir(), 'lamina_%s' % t['name'])
            subprocess.run([args.lamina, 'render', os.path.join(ROOT, 'scenes', 'spheres', 'spheres_0.gltf'), '--stack', t['path'],
                            '--subsurface', 'table', '--width', '128', '--height', '128', '--spp', '64', '--tone-curve', 'clamp',
                            '-o', out + '.exr', '--png', out + '.png'], check=True, capture_output=True)
            axes[0, k].imshow(plt.imread(out + '.png'))
        axes[0, k].set_title(t['name'].replace('skin_', ''), fontsize=9)
        patch = np.ones((20, 40, 3))
        patch[:, :20] = encode(t['spectral_rgb'])
        patch[:, 20:] = encode(t['rgb'])
        axes[1, k].imshow(patch)
        axes[1, k].set_xlabel('spectrum | RGB', fontsize=7)
        for ax in axes[:, k]:
            ax.set_xticks([])
            ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(os.path.join(IMAGES, 'skin_tones_swatches.png'), dpi=90)

    print('| preset | melanin | eumelanin share | blood | oxygen saturation | mu_s\'(500), 1/mm | stands for | colour of the spectrum | RGB mode | CIEDE2000 |')
    print('| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |')
    for t in tones:
        c = t['stack']['layers'][0]['chromophores'], t['stack']['layers'][1]['chromophores']
        de = delta_e(t['spectral_rgb'], t['rgb'])
        who = ('subjects ' + ', '.join(map(str, t['subjects']))) if t['subjects'] else t['source']
        print('| %s | %.4f | %.2f | %.4f | %.2f | %.2f | %s | %s | %s | %s |' % (
            t['name'], c[0]['melanin'], c[0]['eumelanin'], c[1]['blood'], c[1]['oxygenation'], c[1]['scattering']['reduced_500'], who,
            ', '.join('%.3f' % x for x in t['spectral_rgb']), ', '.join('%.3f' % x for x in t['rgb']),
            '%.2f' % de if de is not None else 'n/a'))


if __name__ == '__main__':
    main()
