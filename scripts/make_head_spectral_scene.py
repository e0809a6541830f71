#!/usr/bin/env python3
"""scenes/head_skin/head_skin_spectral.gltf and its maps: head_skin with a material given by
chromophores (skin_chromophores_conserving.json: a sebum film under the head's rough
energy-conserving top, an epidermis with melanin, a dermis with blood) whose melanin and blood
maps are fitted spectrally to the head's albedo photograph (`lamina fit --albedo-texture` with
chromophore parameters: the colour under D65 of the stack's diffuse albedo spectrum, solved by
adding-doubling per wavelength; docs/fitting.md, "The spectral variant").

Writes into scenes/head_skin/:
  melanin_spectral.png      epidermal melanin volume fraction, 16-bit linear over MELANIN's range
  blood_spectral.png        dermal blood volume fraction, 16-bit linear over BLOOD's range
  fitted_albedo_spectral.png  the colour those maps give (8-bit sRGB), to set beside Map-COL.jpg
  albedo_fit_spectral.json  the fit's report (colour differences, clamped texels, times)
  head_skin_spectral.gltf   head_skin.gltf (same mesh, camera, lights, oil maps) with that material

    python3 scripts/make_head_spectral_scene.py [--lamina build/renderer/lamina]

Needs oiiotool (to resize the photo to the maps' 512 x 512, as make_head_skin_scene.py does).
About a minute on 2 cores.
"""
import argparse
import copy
import json
import os
import shutil
import subprocess
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
HEAD = os.path.join(ROOT, 'scenes', 'lee_perry_smith_head')
OUT = os.path.join(ROOT, 'scenes', 'head_skin')
SIZE = 512
MATERIAL = 'skin_chromophores_conserving.json'
# Epidermal melanin 0-20 % (Jacques 2013: 1.3-6.3 % in light skin, more under brows and stubble
# painted into the photo), dermal blood 0-10 % (Jacques 2013: 0.2-7 % in the dermis; lips more).
MELANIN = ('layers[1].chromophores.melanin', 0.0, 0.2)
BLOOD = ('layers[2].chromophores.blood', 0.0, 0.1)


def fit(lamina):
    with tempfile.TemporaryDirectory() as tmp:
        col = os.path.join(tmp, 'col.png')
        subprocess.run(['oiiotool', os.path.join(HEAD, 'Map-COL.jpg'), '--resize', '%dx%d' % (SIZE, SIZE), '-o', col],
                       check=True)
        out = os.path.join(tmp, 'fit')
        os.makedirs(out)
        subprocess.run([lamina, 'fit', os.path.join(OUT, MATERIAL), '--albedo-texture', col, '--threads', '0',
                        '--out-dir', out, '--param', '%s=%g:%g' % MELANIN, '--param', '%s=%g:%g' % BLOOD], check=True)
        report = json.load(open(os.path.join(out, 'albedo_fit.json')))
        assert report['method'] == 'spectral-albedo-lookup', report['method']
        for (name, lo, hi), dest in ((MELANIN, 'melanin_spectral.png'), (BLOOD, 'blood_spectral.png')):
            entry = next(p for p in report['parameters'] if p['name'] == name)
            assert (entry['lower'], entry['upper']) == (lo, hi), entry
            shutil.copyfile(os.path.join(out, entry['map']), os.path.join(OUT, dest))
        shutil.copyfile(os.path.join(out, 'fitted_albedo.png'), os.path.join(OUT, 'fitted_albedo_spectral.png'))
        # The report names the temporary files; keep the numbers.
        for key in ('texture', 'stack', 'materials_map', 'fitted_albedo'):
            report.pop(key, None)
        for p in report['parameters']:
            p.pop('map', None)
        with open(os.path.join(OUT, 'albedo_fit_spectral.json'), 'w') as f:
            json.dump(report, f, indent=2)
            f.write('\n')


def scene():
    gltf = json.load(open(os.path.join(OUT, 'head_skin.gltf')))
    out = copy.deepcopy(gltf)
    material = out['materials'][0]['extras']['lamina']
    # The oil maps (the sebum film's index and the top's roughness) stay as head_skin binds them.
    oil = [b for b in material['bind'] if b['parameter'] in ('layers[0].ior', 'roughness')]
    assert len(oil) == 2, material['bind']

    def bind(spec, texture):
        return {'parameter': spec[0], 'texture': texture, 'channel': 'r', 'range': [spec[1], spec[2]]}

    material['stack'] = MATERIAL
    material['bind'] = [bind(MELANIN, 'melanin_spectral.png'), bind(BLOOD, 'blood_spectral.png')] + oil
    material.pop('freckles', None)
    out['asset']['extras']['lamina'] = (
        'Lamina demo wrapper of ../lee_perry_smith_head/LeePerrySmith_textured.gltf (written by '
        'scripts/make_head_spectral_scene.py from head_skin.gltf): the skin given by chromophores, its '
        'melanin and blood maps fitted spectrally to the albedo photograph; mesh, camera, lights and oil maps '
        'as head_skin.gltf.')
    with open(os.path.join(OUT, 'head_skin_spectral.gltf'), 'w') as f:
        json.dump(out, f, indent=1)
        f.write('\n')


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--lamina', default=os.path.join(ROOT, 'build', 'renderer', 'lamina'))
    args = ap.parse_args()
    fit(args.lamina)
    scene()


if __name__ == '__main__':
    main()
