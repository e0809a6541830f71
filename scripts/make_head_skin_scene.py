#!/usr/bin/env python3
"""Writes scenes/head_skin/: the Lee Perry-Smith head with layered skin driven by maps.

  head_skin.gltf     the head (geometry and textures of ../lee_perry_smith_head, referenced, not
                     copied), a camera, a front key light and a rim light, and material extras that
                     bind skin_oily.json's parameters to maps fitted to the asset's own photographs:
  melanin_fitted.png epidermal melanin volume fraction and
  blood_fitted.png   dermal blood volume fraction, both from `lamina fit --albedo-texture` on
                     Map-COL.jpg (the stack's diffuse albedo matched to each texel in CIE L*a*b*;
                     docs/fitting.md), 16-bit linear over the ranges MELANIN and BLOOD below
  fitted_albedo.png  the albedo those two maps give (8-bit sRGB), to set beside Map-COL.jpg
  oil_spec.png       the sebum film and the surface's smoothness: the asset's specular map
                     Map-SPEC.jpg (luminance, its 2nd..98th percentiles stretched to 0..1)
  head_textured.gltf the same head, camera and lights with the asset's own glTF material (no
                     layered skin): the portrait's reference
  head_skin_procedural.gltf  the earlier showcase: blood from the photo's redness (blood.png), a
                     procedural T-zone (oil.png) and procedural freckles (freckle_mask.png); the
                     measurements in docs/ that name it were taken on it
  With --freckles, head_skin.gltf also gets the procedural freckles.

Maps are DATA (stored values, read without sRGB decoding). The UV positions of forehead, nose,
cheeks and chin were read off Map-COL.jpg (the face sits in the middle of the atlas, eyes at
v ~ 0.27, nose tip at v ~ 0.40, mouth at v ~ 0.47).

Units: the head is about 8 units tall, so one unit is roughly 3 cm; the layered model is position
free (light leaves where it entered), so only the stack's mm coefficients and thicknesses matter and
the scene's units do not. Freckle radius and density are in UV units.

Needs oiiotool (OpenImageIO tools) to read the JPEGs and write PNGs, and a built lamina (--lamina,
default build/renderer/lamina) for the fit; pure Python otherwise. About 20 s.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
HEAD = os.path.join(ROOT, 'scenes', 'lee_perry_smith_head')
OUT = os.path.join(ROOT, 'scenes', 'head_skin')
SIZE = 512
# The fitted parameters of skin_oily.json and their ranges (the maps store (value - LO) / (HI - LO)).
# Epidermal melanin 0-30 % spans the lightest to very dark skin (Jacques 2013: 1-3 % light, 18-43 %
# dark); dermal blood 0-20 % reaches the lips' red (Jacques 2013: 0.2-7 % in the dermis).
MELANIN = ('layers[1].components[0].fraction', 0.0, 0.12)
BLOOD = ('layers[2].components[0].fraction', 0.0, 0.12)

from make_head_scene import add_portrait_rig  # noqa: E402 (sibling script)


def read_ppm(path):
    data = open(path, 'rb').read()
    # Header: P6, width, height, maxval, each separated by whitespace (no comments from oiiotool).
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        start = pos
        while not data[pos:pos + 1].isspace():
            pos += 1
        fields.append(data[start:pos])
    pos += 1
    assert fields[0] == b'P6' and fields[3] == b'255', fields
    w, h = int(fields[1]), int(fields[2])
    return w, h, data[pos:pos + w * h * 3]


def write_png_grey(path, values):
    """values: SIZE*SIZE floats in [0, 1], row-major from the top row, written as 8-bit grey."""
    with tempfile.TemporaryDirectory() as tmp:
        pgm = os.path.join(tmp, 'map.pgm')
        with open(pgm, 'wb') as f:
            f.write(b'P5 %d %d 255\n' % (SIZE, SIZE))
            f.write(bytes(max(0, min(255, round(255 * v))) for v in values))
        subprocess.run(['oiiotool', pgm, '-o', path], check=True)


def smoothstep(e0, e1, x):
    t = max(0.0, min(1.0, (x - e0) / (e1 - e0)))
    return t * t * (3 - 2 * t)


def box(u, v, u0, u1, v0, v1, soft):
    return (smoothstep(u0 - soft, u0 + soft, u) * (1 - smoothstep(u1 - soft, u1 + soft, u)) *
            smoothstep(v0 - soft, v0 + soft, v) * (1 - smoothstep(v1 - soft, v1 + soft, v)))


def blob(u, v, cu, cv, s):
    return math.exp(-((u - cu) ** 2 + (v - cv) ** 2) / (2 * s * s))


def read_rgb(jpeg):
    """The texture resized to SIZE x SIZE, as 8-bit RGB bytes (row-major from the top row)."""
    with tempfile.TemporaryDirectory() as tmp:
        ppm = os.path.join(tmp, 'col.ppm')
        subprocess.run(['oiiotool', jpeg, '--resize', '%dx%d' % (SIZE, SIZE), '-d', 'uint8', '-o', ppm],
                       check=True)
        w, h, px = read_ppm(ppm)
    assert (w, h) == (SIZE, SIZE)
    return px


def stretched(values):
    """values stretched between their 2nd and 98th percentiles to 0..1 (clamped)."""
    s = sorted(values)
    lo, hi = s[int(0.02 * len(s))], s[int(0.98 * len(s))]
    return [max(0.0, min(1.0, (x - lo) / (hi - lo))) for x in values]


def redness_map():
    """The procedural scene's blood map: the redness (R - G) / (R + G + B) of the albedo photo."""
    px = read_rgb(os.path.join(HEAD, 'Map-COL.jpg'))
    return stretched([(px[3 * i] - px[3 * i + 1]) / max(1, sum(px[3 * i:3 * i + 3]))
                      for i in range(SIZE * SIZE)])


def spec_oil_map():
    """The sebum film from the asset's specular map: brighter specular = oilier, smoother skin."""
    px = read_rgb(os.path.join(HEAD, 'Map-SPEC.jpg'))
    return stretched([(0.2126 * px[3 * i] + 0.7152 * px[3 * i + 1] + 0.0722 * px[3 * i + 2]) / 255
                      for i in range(SIZE * SIZE)])


def fitted_maps(lamina):
    """melanin_fitted.png, blood_fitted.png, fitted_albedo.png: `lamina fit --albedo-texture` on
    the albedo photo, on skin_oily_smooth.json (the fit took only smooth tops when the maps were
    made; it now takes the rough one too, but a refit would change the head's renders): the
    diffuse albedo it matches (R_h less the specular reflection) is what the scene's
    energy-conserving rough top leaves too (docs/fitting.md)."""
    with tempfile.TemporaryDirectory() as tmp:
        col = os.path.join(tmp, 'col.png')
        subprocess.run(['oiiotool', os.path.join(HEAD, 'Map-COL.jpg'), '--resize', '%dx%d' % (SIZE, SIZE),
                        '-o', col], check=True)
        fit = os.path.join(tmp, 'fit')
        os.makedirs(fit)
        subprocess.run([lamina, 'fit', os.path.join(ROOT, 'scenes', 'materials', 'skin_oily_smooth.json'),
                        '--albedo-texture', col, '--threads', '0', '--out-dir', fit,
                        '--param', '%s=%g:%g' % MELANIN, '--param', '%s=%g:%g' % BLOOD], check=True)
        report = json.load(open(os.path.join(fit, 'albedo_fit.json')))
        for (name, lo, hi), out in ((MELANIN, 'melanin_fitted.png'), (BLOOD, 'blood_fitted.png')):
            entry = next(p for p in report['parameters'] if p['name'] == name)
            assert (entry['lower'], entry['upper']) == (lo, hi), entry
            shutil.copyfile(os.path.join(fit, entry['map']), os.path.join(OUT, out))
        shutil.copyfile(os.path.join(fit, 'fitted_albedo.png'), os.path.join(OUT, 'fitted_albedo.png'))


def oil_map():
    vals = []
    for y in range(SIZE):
        v = (y + 0.5) / SIZE
        for x in range(SIZE):
            u = (x + 0.5) / SIZE
            forehead = box(u, v, 0.36, 0.64, 0.07, 0.22, 0.03)
            nose = box(u, v, 0.46, 0.54, 0.22, 0.42, 0.02)
            chin = blob(u, v, 0.5, 0.57, 0.035)
            vals.append(max(forehead, nose, chin))
    return vals


def freckle_mask():
    vals = []
    for y in range(SIZE):
        v = (y + 0.5) / SIZE
        for x in range(SIZE):
            u = (x + 0.5) / SIZE
            m = max(blob(u, v, 0.38, 0.36, 0.055), blob(u, v, 0.62, 0.36, 0.055), blob(u, v, 0.5, 0.32, 0.03))
            vals.append(m)
    return vals


def bind(parameter, texture, lo, hi):
    return {'parameter': parameter, 'texture': texture, 'channel': 'r', 'range': [lo, hi]}


def oil_bindings(texture):
    return [
        # The sebum film: index 1.40 (= the epidermis: the film is optically absent) where dry,
        # 1.47 (skin surface lipids, Tuchin 2007) where oily. A clear film's thickness does not
        # matter in the position-free model (no absorption, no scattering, no interference), its
        # index does: it sets the Fresnel reflection of the top interface.
        bind('layers[0].ior', texture, 1.40, 1.47),
        # The skin surface's roughness (GGX alpha of the top interface): 0.4 where dry, 0.2 where
        # oily (the film fills the surface's micro-relief and makes it smoother and glossier).
        # Measured faces: Torrance-Sparrow (Beckmann) roughness m = 0.3-0.45 (Weyrich et al.,
        # "Analysis of Human Faces using a Measurement-Based Skin Reflectance Model", SIGGRAPH
        # 2006, Table 2), and GGX alpha ~ Beckmann m.
        bind('roughness', texture, 0.4, 0.2),
    ]


# Freckles: melanin fraction +0 .. +6 % in spots of ~1.5 mm (radius 0.004 in UV, the face spans
# ~0.3 UV for ~15 cm) on the cheeks and nose.
FRECKLES = {'parameter': 'layers[1].components[0].fraction', 'density': 2500, 'radius': 0.004,
            'amplitude': 0.06, 'seed': 7, 'mask': {'texture': 'freckle_mask.png', 'channel': 'r'}}


def write_gltf(j, name, note, extras):
    j = json.loads(json.dumps(j))
    j['asset'].setdefault('extras', {})['lamina'] = note
    if extras is None:
        j['materials'][0].pop('extras', None)
    else:
        j['materials'][0]['extras'] = {'lamina': extras}
    with open(os.path.join(OUT, name), 'w') as f:
        json.dump(j, f, indent=1)
        f.write('\n')


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--lamina', default=os.path.join(ROOT, 'build', 'renderer', 'lamina'))
    parser.add_argument('--freckles', action='store_true', help='add the procedural freckles to head_skin.gltf')
    args = parser.parse_args()
    os.makedirs(OUT, exist_ok=True)
    fitted_maps(args.lamina)
    write_png_grey(os.path.join(OUT, 'oil_spec.png'), spec_oil_map())
    write_png_grey(os.path.join(OUT, 'blood.png'), redness_map())
    write_png_grey(os.path.join(OUT, 'oil.png'), oil_map())
    write_png_grey(os.path.join(OUT, 'freckle_mask.png'), freckle_mask())

    j = json.load(open(os.path.join(HEAD, 'LeePerrySmith_textured.gltf')))
    for b in j['buffers']:
        b['uri'] = '../lee_perry_smith_head/' + b['uri']
    for im in j['images']:
        im['uri'] = '../lee_perry_smith_head/' + im['uri']
    # The key at ~12 units gives irradiance ~ 500/144 ~ 3.5 on the face; the rim light grazes the
    # head from behind.
    add_portrait_rig(j, eye=(2.0, 1.0, 12.0), target=(0.0, 0.3, 0.0), key_position=(4.0, 3.0, 11.0),
                     key_color=(1.0, 0.97, 0.93), key_intensity=500.0, rim_from=(-6.0, 3.0, -6.0),
                     rim_intensity=4.0)
    # skin_oily.json (with the energy-conserving rough top, the default model, which keeps
    # the albedo the maps were fitted to on the smooth stack): layers[0] sebum film, layers[1]
    # epidermis (components[0] melanin), layers[2] dermis (components[0] blood).
    fitted = {'stack': '../materials/skin_oily.json',
              'bind': [bind(MELANIN[0], 'melanin_fitted.png', *MELANIN[1:]),
                       bind(BLOOD[0], 'blood_fitted.png', *BLOOD[1:])] + oil_bindings('oil_spec.png')}
    if args.freckles:
        fitted['freckles'] = FRECKLES
    write_gltf(j, 'head_skin.gltf',
               'Lamina demo wrapper of ../lee_perry_smith_head/LeePerrySmith_textured.gltf (written by '
               'scripts/make_head_skin_scene.py): layered skin driven by maps fitted to the asset\'s '
               'albedo and specular photographs, a camera, a front key light and a rim light; geometry '
               'and textures unchanged and referenced.', fitted)
    procedural = {'stack': '../materials/skin_oily.json',
                  # Blood volume fraction 0.5 % .. 4 % (Jacques 2013; Donner and Jensen 2006: 0.1-5 %).
                  'bind': [bind('layers[2].components[0].fraction', 'blood.png', 0.005, 0.04)] +
                  oil_bindings('oil.png'),
                  'freckles': FRECKLES}
    write_gltf(j, 'head_skin_procedural.gltf',
               'Lamina demo wrapper of ../lee_perry_smith_head/LeePerrySmith_textured.gltf (written by '
               'scripts/make_head_skin_scene.py): layered skin driven by procedural maps, a camera, a '
               'front key light and a rim light; geometry and textures unchanged and referenced.',
               procedural)
    # The same head, camera and lights with the asset's own glTF material (base colour texture,
    # normal map, metallic-roughness): the portrait's reference beside the layered skin.
    write_gltf(j, 'head_textured.gltf', 'The textured glTF head in the rig of head_skin.gltf (written by '
               'scripts/make_head_skin_scene.py): no layered material.', None)


if __name__ == '__main__':
    main()
