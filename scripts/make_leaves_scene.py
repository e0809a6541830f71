#!/usr/bin/env python3
"""Writes scenes/leaves/: a fan of five procedural leaves with the layered leaf preset, twice:
leaves_front.gltf (a point light on the camera's side) and leaves_back.gltf (the same light
behind the leaves), sharing leaves.bin and leaf_pigment.png; and leaves_{front,back}_rough.gltf,
the same with leaf_rough.json (rough cuticles on both faces, the energy-conserving model).

The leaves are made here (no alpha-masked cards: the renderer has no alpha masking): each is a
triangle strip along its midrib, half-width w(x) = 0.22 sin(pi x)^0.7 for x in [0, 1] (a pointed
ovate blade), cupped across (z = 0.06 (y / w_max)^2) and bent along its length. UV: u runs
along the midrib from base to tip, v across the blade (0.5 on the midrib).

leaf_pigment.png (DATA, stored values) drives the chloroplast volume fraction of the mesophyll
(leaf.json layers[1].components[0]) between 0.18 on the veins and 0.30 on the blade: veins hold
less chlorophyll, so they glow paler when the leaf is lit from behind. The veins are the midrib
and six pairs of lateral veins leaving it at 50 degrees, 0.012 UV wide with soft edges.

Units: the leaves are 1 unit long (a leaf ~8 cm long); the layered model is position free, so
the scene's units do not matter for the stack (mm coefficients).
"""
import base64
import json
import math
import os
import struct
import subprocess
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
OUT = os.path.join(ROOT, 'scenes', 'leaves')
SIZE = 256


def leaf_mesh(nx=40, ny=8):
    pos, nrm, uv, idx = [], [], [], []
    wmax = 0.22

    def surface(x, s):  # s in [-1, 1] across the blade
        w = wmax * math.sin(math.pi * x) ** 0.7
        y = s * w
        z = 0.06 * (y / wmax) ** 2 - 0.12 * x * x  # cupped, and bent back towards the tip
        return [x, y, z]

    # x runs over [0.005, 0.995], not [0, 1]: at the base and the tip the blade has zero width,
    # and a row of coincident vertices would only make degenerate triangles.
    def row_x(i):
        return 0.005 + 0.99 * i / nx

    for i in range(nx + 1):
        x = row_x(i)
        for j in range(ny + 1):
            s = -1 + 2 * j / ny
            pos.append(surface(x, s))
            uv.append([x, 0.5 + 0.5 * s])
    # Normals by central differences of the parametric surface (+z side is the upper face).
    for i in range(nx + 1):
        x = row_x(i)
        for j in range(ny + 1):
            s = -1 + 2 * j / ny
            e = 1e-4
            a = [p - q for p, q in zip(surface(min(x + e, 1), s), surface(max(x - e, 0), s))]
            b = [p - q for p, q in zip(surface(x, min(s + e, 1)), surface(x, max(s - e, -1)))]
            n = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
            ln = math.sqrt(sum(c * c for c in n))
            nrm.append([c / ln for c in n] if ln > 1e-12 else [0.0, 0.0, 1.0])
    for i in range(nx):
        for j in range(ny):
            a = i * (ny + 1) + j
            b, c, d = a + 1, a + ny + 1, a + ny + 2
            idx += [a, c, b, b, c, d]
    return pos, nrm, uv, idx


def pigment_map():
    def vein_distance(u, v):
        d = abs(v - 0.5)  # midrib
        for k in range(6):
            u0 = 0.12 + 0.13 * k  # where the lateral vein leaves the midrib
            # Lateral veins at 50 degrees to the midrib, towards the tip: u - u0 = |v - 0.5| cot(50).
            t = abs(v - 0.5)
            du = u - (u0 + t / math.tan(math.radians(50)))
            d = min(d, abs(du) * math.sin(math.radians(50)))
        return d

    vals = []
    for y in range(SIZE):
        v = (y + 0.5) / SIZE
        for x in range(SIZE):
            u = (x + 0.5) / SIZE
            d = vein_distance(u, v)
            t = min(1.0, max(0.0, (d - 0.006) / 0.01))  # 0 on a vein, 1 on the blade
            vals.append(t)
    return vals


def main():
    os.makedirs(OUT, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        pgm = os.path.join(tmp, 'p.pgm')
        with open(pgm, 'wb') as f:
            f.write(b'P5 %d %d 255\n' % (SIZE, SIZE))
            f.write(bytes(max(0, min(255, round(255 * v))) for v in pigment_map()))
        subprocess.run(['oiiotool', pgm, '-o', os.path.join(OUT, 'leaf_pigment.png')], check=True)

    pos, nrm, uv, idx = leaf_mesh()
    blob = b''.join(struct.pack('<3f', *p) for p in pos)
    nrm_off = len(blob)
    blob += b''.join(struct.pack('<3f', *n) for n in nrm)
    uv_off = len(blob)
    blob += b''.join(struct.pack('<2f', *t) for t in uv)
    idx_off = len(blob)
    blob += b''.join(struct.pack('<I', i) for i in idx)
    open(os.path.join(OUT, 'leaves.bin'), 'wb').write(blob)
    nv = len(pos)
    mins = [min(p[k] for p in pos) for k in range(3)]
    maxs = [max(p[k] for p in pos) for k in range(3)]

    def scene(light_pos, name, stack='leaf.json'):
        j = {
            'asset': {'version': '2.0', 'generator': 'scripts/make_leaves_scene.py'},
            'extensionsUsed': ['KHR_lights_punctual'],
            'buffers': [{'uri': 'leaves.bin', 'byteLength': len(blob)}],
            'bufferViews': [
                {'buffer': 0, 'byteOffset': 0, 'byteLength': nrm_off},
                {'buffer': 0, 'byteOffset': nrm_off, 'byteLength': uv_off - nrm_off},
                {'buffer': 0, 'byteOffset': uv_off, 'byteLength': idx_off - uv_off},
                {'buffer': 0, 'byteOffset': idx_off, 'byteLength': len(blob) - idx_off}],
            'accessors': [
                {'bufferView': 0, 'componentType': 5126, 'count': nv, 'type': 'VEC3', 'min': mins, 'max': maxs},
                {'bufferView': 1, 'componentType': 5126, 'count': nv, 'type': 'VEC3'},
                {'bufferView': 2, 'componentType': 5126, 'count': nv, 'type': 'VEC2'},
                {'bufferView': 3, 'componentType': 5125, 'count': len(idx), 'type': 'SCALAR'}],
            'materials': [{
                'name': 'leaf', 'doubleSided': True,
                'pbrMetallicRoughness': {'baseColorFactor': [0.08, 0.25, 0.05, 1.0], 'metallicFactor': 0.0},
                'extras': {'lamina': {
                    'stack': '../materials/' + stack,
                    'bind': [{'parameter': 'layers[1].components[0].fraction', 'texture': 'leaf_pigment.png',
                              'channel': 'r', 'range': [0.18, 0.30]}]}}}],
            'meshes': [{'name': 'leaf', 'primitives': [{'attributes': {'POSITION': 0, 'NORMAL': 1, 'TEXCOORD_0': 2},
                                                        'indices': 3, 'material': 0}]}],
            'cameras': [{'name': 'view', 'type': 'perspective', 'perspective': {'yfov': 0.6, 'znear': 0.05}}],
            'extensions': {'KHR_lights_punctual': {'lights': [
                {'name': 'sun', 'type': 'point', 'color': [1.0, 0.98, 0.95], 'intensity': 40.0}]}},
            'nodes': [], 'scenes': [{'name': name, 'nodes': []}], 'scene': 0}
        nodes = j['nodes']
        # Five leaves in a fan from a common base at the origin, each turned about Z and tilted
        # a little about its own midrib so the light meets them at different angles.
        for k, angle in enumerate([-70, -35, 0, 35, 70]):
            a = math.radians(90 + angle)
            tilt = math.radians([-20, 10, 0, -10, 20][k])
            qz = [0.0, 0.0, math.sin(a / 2), math.cos(a / 2)]
            qx = [math.sin(tilt / 2), 0.0, 0.0, math.cos(tilt / 2)]
            # q = qz * qx (tilt about the leaf's own axis first, then turn in the fan)
            w1, x1, y1, z1 = qz[3], qz[0], qz[1], qz[2]
            w2, x2, y2, z2 = qx[3], qx[0], qx[1], qx[2]
            q = [w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                 w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2]
            nodes.append({'name': 'leaf%d' % k, 'mesh': 0, 'rotation': q, 'translation': [0.0, -0.45, 0.02 * k]})
        nodes.append({'name': 'view', 'camera': 0, 'translation': [0.0, 0.05, 2.7]})
        nodes.append({'name': 'sun', 'translation': light_pos, 'extensions': {'KHR_lights_punctual': {'light': 0}}})
        j['scenes'][0]['nodes'] = list(range(len(nodes)))
        with open(os.path.join(OUT, name + '.gltf'), 'w') as f:
            json.dump(j, f, indent=1)
            f.write('\n')

    # Front: the light beside the camera. Back: the same light mirrored behind the leaves.
    scene([0.8, 0.9, 2.5], 'leaves_front')
    scene([0.4, 0.6, -2.5], 'leaves_back')
    scene([0.8, 0.9, 2.5], 'leaves_front_rough', 'leaf_rough.json')
    scene([0.4, 0.6, -2.5], 'leaves_back_rough', 'leaf_rough.json')


if __name__ == '__main__':
    main()
