#!/usr/bin/env python3
"""Writes scenes/head_skin/: the Lee Perry-Smith head with the layered skin preset driven by maps.

  head_skin.gltf   the head (geometry and textures of ../lee_perry_smith_head, referenced, not
                   copied), a camera, a front key light and a rim light, and material extras that
                   bind skin_oily.json's parameters to the maps below (renderer/layered/stack_bindings.h)
  blood.png        dermal blood volume fraction: the redness of the albedo map
                   (R - G) / (R + G + B), its 2nd..98th percentiles stretched to 0..1, so lips and
                   cheeks get more blood than the bearded chin and the scalp
  oil.png          the sebum film: a procedural T-zone (forehead band, nose, chin) drawn in the
                   face's UV layout, smooth-edged
  freckle_mask.png where freckles may appear: cheeks and the bridge of the nose (Gaussian blobs)
  head_textured.gltf the same head, camera and lights with the asset's own glTF material (no
                   layered skin): the portrait's reference

Maps are DATA (stored values, read without sRGB decoding). The UV positions of forehead, nose,
cheeks and chin were read off Map-COL.jpg (the face sits in the middle of the atlas, eyes at
v ~ 0.27, nose tip at v ~ 0.40, mouth at v ~ 0.47).

Units: the head is about 8 units tall, so one unit is roughly 3 cm; the layered model is position
free (light leaves where it entered), so only the stack's mm coefficients and thicknesses matter and
the scene's units do not. Freckle radius and density are in UV units.

Needs oiiotool (OpenImageIO tools) to read the JPEG and write PNGs; pure Python otherwise.
"""
import json
import math
import os
import subprocess
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
HEAD = os.path.join(ROOT, 'scenes', 'lee_perry_smith_head')
OUT = os.path.join(ROOT, 'scenes', 'head_skin')
SIZE = 512

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


def blood_map():
    with tempfile.TemporaryDirectory() as tmp:
        ppm = os.path.join(tmp, 'col.ppm')
        subprocess.run(['oiiotool', os.path.join(HEAD, 'Map-COL.jpg'), '--resize', '%dx%d' % (SIZE, SIZE),
                        '-d', 'uint8', '-o', ppm], check=True)
        w, h, px = read_ppm(ppm)
    redness = []
    for i in range(w * h):
        r, g, b = px[3 * i], px[3 * i + 1], px[3 * i + 2]
        redness.append((r - g) / max(1, r + g + b))
    s = sorted(redness)
    lo, hi = s[int(0.02 * len(s))], s[int(0.98 * len(s))]
    return [max(0.0, min(1.0, (x - lo) / (hi - lo))) for x in redness]


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


def main():
    os.makedirs(OUT, exist_ok=True)
    write_png_grey(os.path.join(OUT, 'blood.png'), blood_map())
    write_png_grey(os.path.join(OUT, 'oil.png'), oil_map())
    write_png_grey(os.path.join(OUT, 'freckle_mask.png'), freckle_mask())

    j = json.load(open(os.path.join(HEAD, 'LeePerrySmith_textured.gltf')))
    j['asset'].setdefault('extras', {})['lamina'] = (
        'Lamina demo wrapper of ../lee_perry_smith_head/LeePerrySmith_textured.gltf (written by '
        'scripts/make_head_skin_scene.py): layered skin driven by maps, a camera, a front key light '
        'and a rim light; geometry and textures unchanged and referenced.')
    for b in j['buffers']:
        b['uri'] = '../lee_perry_smith_head/' + b['uri']
    for im in j['images']:
        im['uri'] = '../lee_perry_smith_head/' + im['uri']
    # skin_oily.json: layers[0] sebum film, layers[1] epidermis (components[0] melanin),
    # layers[2] dermis (components[0] blood).
    j['materials'][0]['extras'] = {'lamina': {
        'stack': '../materials/skin_oily.json',
        'bind': [
            # Blood volume fraction 0.5 % .. 4 % (Jacques 2013; Donner and Jensen 2006: 0.1-5 %).
            {'parameter': 'layers[2].components[0].fraction', 'texture': 'blood.png', 'channel': 'r',
             'range': [0.005, 0.04]},
            # The sebum film: index 1.40 (= the epidermis: the film is optically absent) where dry,
            # 1.47 (skin surface lipids, Tuchin 2007) on the T-zone. A clear film's thickness does
            # not matter in the position-free model (no absorption, no scattering, no
            # interference), its index does: it sets the Fresnel reflection of the top interface.
            {'parameter': 'layers[0].ior', 'texture': 'oil.png', 'channel': 'r', 'range': [1.40, 1.47]},
            # The skin surface's roughness (GGX alpha of the top interface): 0.4 where dry, 0.2
            # where oily (the film fills the surface's micro-relief and makes it smoother and
            # glossier). Measured faces: Torrance-Sparrow (Beckmann) roughness m = 0.3-0.45
            # (Weyrich et al., "Analysis of Human Faces using a Measurement-Based Skin
            # Reflectance Model", SIGGRAPH 2006, Table 2), and GGX alpha ~ Beckmann m.
            {'parameter': 'roughness', 'texture': 'oil.png', 'channel': 'r', 'range': [0.4, 0.2]},
        ],
        # Freckles: melanin fraction +0 .. +6 % in spots of ~1.5 mm (radius 0.004 in UV, the face
        # spans ~0.3 UV for ~15 cm) on the cheeks and nose.
        'freckles': {'parameter': 'layers[1].components[0].fraction', 'density': 2500, 'radius': 0.004,
                     'amplitude': 0.06, 'seed': 7,
                     'mask': {'texture': 'freckle_mask.png', 'channel': 'r'}},
    }}
    # The key at ~12 units gives irradiance ~ 500/144 ~ 3.5 on the face; the rim light grazes the
    # head from behind.
    add_portrait_rig(j, eye=(2.0, 1.0, 12.0), target=(0.0, 0.3, 0.0), key_position=(4.0, 3.0, 11.0),
                     key_color=(1.0, 0.97, 0.93), key_intensity=500.0, rim_from=(-6.0, 3.0, -6.0),
                     rim_intensity=4.0)
    with open(os.path.join(OUT, 'head_skin.gltf'), 'w') as f:
        json.dump(j, f, indent=1)
        f.write('\n')
    # The same head, camera and lights with the asset's own glTF material (base colour texture,
    # normal map, metallic-roughness): the portrait's reference beside the layered skin.
    del j['materials'][0]['extras']
    j['asset']['extras']['lamina'] = ('The textured glTF head in the rig of head_skin.gltf (written by '
                                      'scripts/make_head_skin_scene.py): no layered material.')
    with open(os.path.join(OUT, 'head_textured.gltf'), 'w') as f:
        json.dump(j, f, indent=1)
        f.write('\n')


if __name__ == '__main__':
    main()
