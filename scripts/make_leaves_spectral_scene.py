#!/usr/bin/env python3
"""Writes scenes/leaves_spectral/: the five leaves of scenes/leaves (the same geometry,
../leaves/leaves.bin, and the same front and back point light) as layered leaves by pigment
(docs/spectral.md, "Layered leaf"), one chlorophyll content per leaf from green to yellowing:
leaves_spectral_front.gltf, leaves_spectral_back.gltf and the five material files
leaf_chlorophyll_NN.json (NN the leaf's chlorophyll a+b, ug/cm2).

Each material is scenes/spectral/leaf_layered_smooth.json (the mature green leaf as fitted with
smooth faces, 40 ug/cm2: the renderer does not read the diffuse faces of leaf_layered.json yet)
with its chlorophyll scaled in both pigment layers (palisade and spongy mesophyll keep their
shares); the carotenoids, water, dry matter and scattering stay, as in a leaf that yellows: its
chlorophyll is broken down before its carotenoids (the senescent leaf of docs/spectral.md keeps
0.8 ug/cm2 of chlorophyll). Leaf k of the fan (leaf0 .. leaf4) gets CHLOROPHYLL[k].

Only `lamina render --spectral` reads leaf layers (the RGB mode refuses them). For the RGB mode,
each material also gets an RGB counterpart, leaf_chlorophyll_NN_rgb.json (the same layers and
thicknesses, glTF materials bound by a material map, leaves_rgb_materials.json): each coefficient
of a leaf layer (absorption K(lambda)/d and scattering, docs/spectral.md "Layered leaf", computed
here from materials/spectral/prospect_d_data.cpp) projected on the RGB channels by the uplift's
basis (materials/spectral/uplift_data.cpp): sigma_c = sum B_c(lambda) sigma(lambda) / sum
B_c(lambda) over 380-780 nm every 5 nm, the channel's share of each wavelength as the spectral
mode's uplift gives it; the index PROSPECT-D's at 550 nm. A projection of coefficients, not of
colours: the difference of the two renders is what rendering a pigment leaf in RGB costs.
"""
import copy
import json
import math
import os
import re

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
OUT = os.path.join(ROOT, 'scenes', 'leaves_spectral')
CHLOROPHYLL = [40.0, 28.0, 18.0, 9.0, 3.0]  # ug/cm2, leaf0 .. leaf4


def material(chlorophyll):
    with open(os.path.join(ROOT, 'scenes', 'spectral', 'leaf_layered_smooth.json')) as f:
        leaf = json.load(f)
    total = sum(layer['leaf'].get('chlorophyll', 0.0) for layer in leaf['layers'])
    for layer in leaf['layers']:
        if 'chlorophyll' in layer['leaf']:
            layer['leaf']['chlorophyll'] = round(layer['leaf']['chlorophyll'] * chlorophyll / total, 4)
    leaf['name'] = 'leaf_chlorophyll_%02d' % round(chlorophyll)
    return leaf


def table(name, columns):
    """Rows of a generated table in materials/spectral/NAME: lists of `columns` floats."""
    with open(os.path.join(ROOT, 'materials', 'spectral', name)) as f:
        text = f.read()
    rows = re.findall(r'\{(' + ', '.join([r'([-+0-9.e]+)'] * columns) + r')\}', text)
    return [[float(v) for v in r[1:]] for r in rows]


PROSPECT = {r[0]: r for r in table('prospect_d_data.cpp', 8)}  # nm, n, Kab, Kcar, Kant, Kbrown, Kw, Km
BASIS = table('uplift_data.cpp', 4)  # nm, B_r, B_g, B_b
KEYS = ['chlorophyll', 'carotenoids', 'anthocyanins', 'brown', 'water', 'dry_matter']


def prospect_row(nm):  # held below 400 nm, as materials/spectral/prospect.cpp reads the table
    return PROSPECT[float(max(400, min(2500, round(nm))))]


def average_transmissivity_90(n, steps=2000):
    """t_av(90 degrees, n): the unpolarised Fresnel transmittance averaged over isotropic light,
    integral of T(theta) sin(2 theta) dtheta (materials/spectral/prospect.cpp has Stern's closed form)."""
    total = 0.0
    for i in range(steps):
        t = (i + 0.5) * (math.pi / 2) / steps
        st = math.sin(t) / n
        ct = math.sqrt(1.0 - st * st)
        ci = math.cos(t)
        rs = ((ci - n * ct) / (ci + n * ct)) ** 2
        rp = ((ct - n * ci) / (ct + n * ci)) ** 2
        total += (1.0 - 0.5 * (rs + rp)) * math.sin(2 * t)
    return total * (math.pi / 2) / steps


def plate_depth(nm):  # materials/spectral/leaf_chromophores.cpp: (4/3)(1 - t)/t
    n = prospect_row(nm)[1]
    t12 = average_transmissivity_90(n)
    t21 = t12 / (n * n)
    r21 = 1.0 - t21
    t = t12 * t21 / (1.0 - r21 * r21)
    return 4.0 / 3.0 * (1.0 - t) / t


def rgb_layer(layer):
    """A leaf layer's coefficients projected on the RGB channels (the module's docstring)."""
    leaf, d = layer['leaf'], layer['thickness']
    g = leaf.get('g', 0.0)
    sa, ss = [0.0] * 3, [0.0] * 3
    weights = [0.0] * 3
    for nm, *b in BASIS:
        row = prospect_row(nm)
        k = sum(leaf.get(key, 0.0) * row[2 + i] for i, key in enumerate(KEYS))
        s = leaf.get('plates', 0.0) * plate_depth(nm) * (nm / 1000.0) ** -leaf.get('scattering_power', 0.0) / (d * (1.0 - g))
        for c in range(3):
            sa[c] += b[c] * k / d
            ss[c] += b[c] * s
            weights[c] += b[c]
    out = {'name': layer.get('name', ''), 'ior': prospect_row(550)[1], 'thickness': d,
           'sigma_a': [round(sa[c] / weights[c], 6) for c in range(3)],
           'sigma_s': [round(ss[c] / weights[c], 6) for c in range(3)], 'g': g}
    return out


def rgb_material(leaf):
    m = {'lamina_material': 1, 'name': leaf['name'] + '_rgb', 'layers': [rgb_layer(l) for l in leaf['layers']],
         'below': {'ior': 1.0}}
    return m


def scene(side):
    with open(os.path.join(ROOT, 'scenes', 'leaves', 'leaves_%s.gltf' % side)) as f:
        g = json.load(f)
    g['buffers'][0]['uri'] = '../leaves/leaves.bin'
    base_material = g['materials'][0]
    base_mesh = g['meshes'][0]
    g['materials'], g['meshes'] = [], []
    leaves = [n for n in g['nodes'] if n.get('mesh') == 0]
    for k, node in enumerate(leaves):
        m = copy.deepcopy(base_material)
        m['name'] = 'leaf_chlorophyll_%02d' % round(CHLOROPHYLL[k])
        m['extras'] = {'lamina': {'stack': m['name'] + '.json'}}
        g['materials'].append(m)
        mesh = copy.deepcopy(base_mesh)
        mesh['name'] = 'leaf%d' % k
        mesh['primitives'][0]['material'] = k
        g['meshes'].append(mesh)
        node['mesh'] = k
    for s in g.get('scenes', []):
        s['name'] = 'leaves_spectral_%s' % side
    return g


def main():
    os.makedirs(OUT, exist_ok=True)
    materials_map = {}
    for c in CHLOROPHYLL:
        m = material(c)
        for leaf in (m, rgb_material(m)):
            with open(os.path.join(OUT, leaf['name'] + '.json'), 'w') as f:
                json.dump(leaf, f, indent=2)
                f.write('\n')
        materials_map[m['name']] = m['name'] + '_rgb.json'
    with open(os.path.join(OUT, 'leaves_rgb_materials.json'), 'w') as f:
        json.dump(materials_map, f, indent=2)
        f.write('\n')
    for side in ('front', 'back'):
        with open(os.path.join(OUT, 'leaves_spectral_%s.gltf' % side), 'w') as f:
            json.dump(scene(side), f, indent=1)
            f.write('\n')


if __name__ == '__main__':
    main()
