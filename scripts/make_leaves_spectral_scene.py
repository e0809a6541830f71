#!/usr/bin/env python3
"""Writes scenes/leaves_spectral/: the five leaves of scenes/leaves (the same geometry,
../leaves/leaves.bin, and the same front and back point light) as layered leaves by pigment
(docs/spectral.md, "Layered leaf"), one chlorophyll content per leaf from green to yellowing:
leaves_spectral_front.gltf, leaves_spectral_back.gltf and the five material files
leaf_chlorophyll_NN.json (NN the leaf's chlorophyll a+b, ug/cm2); and
leaves_yellowing_back.gltf, the back-lit fan of one leaf (scenes/spectral/leaf_layered.json)
whose chlorophyll comes from a map, leaf_yellowing.png (DATA, stored values): 1 (40 ug/cm2, the
file's) at the base of the blade, falling to 0 (3 ug/cm2) at the tip and along the margin, as
a leaf yellows from its tip and edges; both pigment layers bound to it, each in its share of the
file's chlorophyll (docs/stack_bindings.md, "Leaf parameters"). UV: u along the midrib from base
to tip, v across the blade (scripts/make_leaves_scene.py).

Each material is scenes/spectral/leaf_layered.json (the mature green leaf as fitted, 40 ug/cm2,
its faces diffuse as the fit chose them) with its chlorophyll scaled in both pigment layers (palisade and spongy mesophyll keep their
shares); the carotenoids, water, dry matter and scattering stay, as in a leaf that yellows: its
chlorophyll is broken down before its carotenoids (the senescent leaf of docs/spectral.md keeps
0.8 ug/cm2 of chlorophyll). Leaf k of the fan (leaf0 .. leaf4) gets CHLOROPHYLL[k].

Only `lamina render --spectral` reads leaf layers (the RGB mode refuses them). For the RGB mode,
each material also gets an RGB reading, leaf_chlorophyll_NN_rgb.json (the same layers and
thicknesses, glTF materials bound by a material map, leaves_rgb_materials.json), fitted to the
leaf's colours (docs/spectral.md, "Leaves by pigment"):

1. each coefficient of a leaf layer (absorption K(lambda)/d and scattering, docs/spectral.md
   "Layered leaf", computed here from materials/spectral/prospect_d_data.cpp) is projected on
   the RGB channels by the uplift's basis (materials/spectral/uplift_data.cpp): sigma_c = sum
   B_c(lambda) sigma(lambda) / sum B_c(lambda) over 380-780 nm every 5 nm; the index is
   PROSPECT-D's at 550 nm. That projection alone is about twice too dark: a band's mean
   coefficient closes the band's clear wavelengths (the mean of e^(-sigma d) exceeds e^(-mean
   sigma d));
2. per channel c, one absorption scale a_c and one scattering scale s_c multiply the projected
   coefficients of every leaf layer, chosen by Newton's method so that the RGB stack's
   reflectance and transmittance (`lamina brdf --method adding-doubling`, light at THETA_DEG)
   equal the colours of the spectral leaf's (`lamina brdf --wavelengths`: CIE 1931 under D65 to
   linear Rec. 709, as the film integrates). The interfaces' specular reflection is the same in
   both (the index at 550 nm against the spectrum's), so the fit matches the diffuse part: the
   spectral total less the RGB stack's specular. A target below FLOOR is raised to FLOOR: the
   transmitted green's blue lies outside the Rec. 709 gamut (negative), and so does the blue of
   the diffuse reflectance of a leaf whose green dominates; an RGB stack cannot make a negative
   channel.

--check reads the committed RGB readings and exits 1 if a channel of their R or T differs from
the spectral leaf's colour (so clamped) by more than TOLERANCE at THETA_DEG, printing both; it
also prints them at 0 and 60 degrees.
"""
import argparse
import subprocess
import tempfile
import copy
import json
import math
import os
import re

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
OUT = os.path.join(ROOT, 'scenes', 'leaves_spectral')
CHLOROPHYLL = [40.0, 28.0, 18.0, 9.0, 3.0]  # ug/cm2, leaf0 .. leaf4


def material(chlorophyll):
    with open(os.path.join(ROOT, 'scenes', 'spectral', 'leaf_layered.json')) as f:
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
    if layer.get('bottom_diffuse'):
        out['bottom_diffuse'] = True
    return out


THETA_DEG = 30.0   # the incidence of the fit (light at 30 degrees from the normal)
FLOOR = 1e-3       # the smallest target of a channel (an RGB stack cannot make a negative one)
TOLERANCE = 2e-4   # --check: the largest difference of a channel of R or T at THETA_DEG
LAMINA = os.path.join(ROOT, 'build', 'renderer', 'lamina')


def brdf(lamina, material, theta, spectral):
    """`lamina brdf --method adding-doubling` of a material (a dict), its totals JSON."""
    with tempfile.TemporaryDirectory() as tmp:
        path, out = os.path.join(tmp, 'm.json'), os.path.join(tmp, 'summary.json')
        with open(path, 'w') as f:
            json.dump(material, f)
        args = [lamina, 'brdf', path, '--theta-i', str(theta), '--method', 'adding-doubling', '--quadrature-points', '16',
                '--summary', out]
        if spectral:
            args += ['--wavelengths', '360:830:5']
        subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
        with open(out) as f:
            return json.load(f)


def spectral_colours(lamina, leaf, theta):
    """The colours (linear Rec. 709 under D65) of the spectral leaf's total R and T at theta."""
    d = brdf(lamina, leaf, theta, True)
    return d['R_rec709'], d['T_rec709']


def rgb_totals(lamina, material, theta):
    """The RGB stack's R (specular, diffuse) and total T at theta, per channel."""
    d = brdf(lamina, material, theta, False)
    return d['R_specular'], d['R_diffuse'], [b + t for b, t in zip(d['T_ballistic'], d['T_diffuse'])]


PROJECTIONS = {}  # rgb_layer's result by the layer's JSON: the fit asks for the same layers often


def rgb_material(leaf, scales=None):
    """The RGB reading of a leaf: each leaf layer's projection, its absorption times a_c and its
    scattering times s_c per channel (scales = (a, s), three each; none: the projection alone)."""
    a, s = scales if scales else ([1.0] * 3, [1.0] * 3)
    layers = []
    for layer in leaf['layers']:
        key = json.dumps(layer, sort_keys=True)
        if key not in PROJECTIONS:
            PROJECTIONS[key] = rgb_layer(layer)
        out = copy.deepcopy(PROJECTIONS[key])
        out['sigma_a'] = [round(out['sigma_a'][c] * a[c], 6) for c in range(3)]
        out['sigma_s'] = [round(out['sigma_s'][c] * s[c], 6) for c in range(3)]
        layers.append(out)
    faces = {'top_diffuse': True} if leaf.get('top_diffuse') else {}
    return {'lamina_material': 1, 'name': leaf['name'] + '_rgb', **faces, 'layers': layers, 'below': {'ior': 1.0}}


def targets(lamina, leaf, specular):
    """Per channel, the diffuse reflectance and the transmittance the RGB stack must have: the
    spectral leaf's colours at THETA_DEG, less the RGB specular reflection, raised to FLOOR."""
    r, t = spectral_colours(lamina, leaf, THETA_DEG)
    return [max(r[c] - specular[c], FLOOR) for c in range(3)], [max(t[c], FLOOR) for c in range(3)]


def fit_scales(lamina, leaf, iterations=40):
    """a_c and s_c of the RGB reading (the module's docstring, step 2): Newton's method on
    (log a_c, log s_c) for (log R_diffuse, log T) per channel, the channels solved together (one
    `lamina brdf` solves all three), derivatives by forward differences, steps at most 1 in the
    logarithms."""
    x = [[0.0, 0.0] for _ in range(3)]  # (log a, log s) per channel
    specular = rgb_totals(lamina, rgb_material(leaf), THETA_DEG)[0]
    want_r, want_t = targets(lamina, leaf, specular)
    h = 1e-4

    def residual(xs):
        m = rgb_material(leaf, ([math.exp(v[0]) for v in xs], [math.exp(v[1]) for v in xs]))
        _, rd, t = rgb_totals(lamina, m, THETA_DEG)
        return [[math.log(max(rd[c], 1e-12) / want_r[c]), math.log(max(t[c], 1e-12) / want_t[c])] for c in range(3)]

    for _ in range(iterations):
        f = residual(x)
        if max(abs(v) for fc in f for v in fc) < 1e-7:
            break
        fa = residual([[v[0] + h, v[1]] for v in x])
        fs = residual([[v[0], v[1] + h] for v in x])
        for c in range(3):
            j = [[(fa[c][0] - f[c][0]) / h, (fs[c][0] - f[c][0]) / h],
                 [(fa[c][1] - f[c][1]) / h, (fs[c][1] - f[c][1]) / h]]
            det = j[0][0] * j[1][1] - j[0][1] * j[1][0]
            if det == 0.0:
                continue
            dx = [-(j[1][1] * f[c][0] - j[0][1] * f[c][1]) / det, -(-j[1][0] * f[c][0] + j[0][0] * f[c][1]) / det]
            step = max(1.0, max(abs(v) for v in dx))
            x[c] = [x[c][0] + dx[0] / step, x[c][1] + dx[1] / step]
    return [math.exp(v[0]) for v in x], [math.exp(v[1]) for v in x]


def check(lamina):
    """--check: the committed RGB readings against the spectral leaves' colours."""
    worst = 0.0
    for c in CHLOROPHYLL:
        leaf = material(c)
        with open(os.path.join(OUT, leaf['name'] + '_rgb.json')) as f:
            rgb = json.load(f)
        for theta in (THETA_DEG, 0.0, 60.0):
            spec, rd, t = rgb_totals(lamina, rgb, theta)
            r = [spec[k] + rd[k] for k in range(3)]
            want_r, want_t = spectral_colours(lamina, leaf, theta)
            clamped_r = [max(want_r[k], spec[k] + FLOOR) for k in range(3)]
            clamped_t = [max(want_t[k], FLOOR) for k in range(3)]
            diff = max(max(abs(r[k] - clamped_r[k]), abs(t[k] - clamped_t[k])) for k in range(3))
            if theta == THETA_DEG:
                worst = max(worst, diff)
            print('%s at %2.0f deg: R rgb %s spectral %s; T rgb %s spectral %s; largest difference %.5f' % (
                leaf['name'], theta, fmt3(r), fmt3(want_r), fmt3(t), fmt3(want_t), diff))
    print('largest difference at %g degrees: %.6f (tolerance %g)' % (THETA_DEG, worst, TOLERANCE))
    return 0 if worst <= TOLERANCE else 1


def fmt3(v):
    return '(%.4f, %.4f, %.4f)' % tuple(v)


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


YELLOWING_SIZE = 256


def yellowing_map():
    """The stored values t of leaf_yellowing.png, rows from v = 0: 1 - smoothstep(0.45, 0.95, d)
    with d = u + 0.45 |2v - 1|^2, which reaches the tip first and the margin before the midrib."""
    vals = []
    for y in range(YELLOWING_SIZE):
        v = (y + 0.5) / YELLOWING_SIZE
        for x in range(YELLOWING_SIZE):
            u = (x + 0.5) / YELLOWING_SIZE
            d = u + 0.45 * abs(2 * v - 1) ** 2
            e = min(1.0, max(0.0, (d - 0.45) / 0.5))
            vals.append(1.0 - e * e * (3 - 2 * e))
    return vals


def yellowing_scene():
    """The back-lit fan, every leaf the fitted leaf with its chlorophyll bound to the map."""
    g = scene('back')
    leaf = material(CHLOROPHYLL[0])
    binds = []
    for i, layer in enumerate(leaf['layers']):
        c = layer['leaf'].get('chlorophyll', 0.0)
        if c > 0.0:
            lo = round(c * CHLOROPHYLL[-1] / CHLOROPHYLL[0], 4)
            binds.append({'parameter': 'layers[%d].leaf.chlorophyll' % i, 'texture': 'leaf_yellowing.png', 'channel': 'r',
                          'range': [lo, c]})
    m = copy.deepcopy(g['materials'][0])
    m['name'] = 'leaf_yellowing'
    m['extras'] = {'lamina': {'stack': '../spectral/leaf_layered.json', 'bind': binds}}
    g['materials'] = [m]
    for mesh in g['meshes']:
        mesh['primitives'][0]['material'] = 0
    for sc in g.get('scenes', []):
        sc['name'] = 'leaves_yellowing_back'
    return g


def write_yellowing_map(path):
    with tempfile.TemporaryDirectory() as tmp:
        pgm = os.path.join(tmp, 'y.pgm')
        with open(pgm, 'wb') as f:
            f.write(b'P5 %d %d 255\n' % (YELLOWING_SIZE, YELLOWING_SIZE))
            f.write(bytes(max(0, min(255, round(255 * v))) for v in yellowing_map()))
        subprocess.run(['oiiotool', pgm, '-o', path], check=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--lamina', default=LAMINA, help='the lamina program (default build/renderer/lamina)')
    parser.add_argument('--check', action='store_true', help='check the committed RGB readings; write nothing')
    args = parser.parse_args()
    if args.check:
        raise SystemExit(check(args.lamina))
    os.makedirs(OUT, exist_ok=True)
    materials_map = {}
    for c in CHLOROPHYLL:
        m = material(c)
        scales = fit_scales(args.lamina, m)
        print('%s: absorption scales %s, scattering scales %s' % (m['name'], fmt3(scales[0]), fmt3(scales[1])))
        for leaf in (m, rgb_material(m, scales)):
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
    write_yellowing_map(os.path.join(OUT, 'leaf_yellowing.png'))
    with open(os.path.join(OUT, 'leaves_yellowing_back.gltf'), 'w') as f:
        json.dump(yellowing_scene(), f, indent=1)
        f.write('\n')


if __name__ == '__main__':
    main()
