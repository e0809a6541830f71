#!/usr/bin/env python3
"""Writes scenes/gltf_leaf/: leaves as a Blender user would export them, with no Lamina stack
file: flat cards whose base colour texture's alpha cuts out the leaf's outline and a few holes
(alphaMode MASK), and KHR_materials_diffuse_transmission (factor 0.45) with a green base colour,
which Lamina maps onto a layered stack (docs/gltf_materials.md). Twice: gltf_leaf_front.gltf
(a directional light from the camera's side) and gltf_leaf_back.gltf (the same light from
behind the leaves), sharing gltf_leaf.bin and leaf_rgba.png.

leaf_rgba.png: RGBA 8-bit, 256 x 256; alpha 1 inside a pointed ovate blade (half-width
0.3 sin(pi x)^0.7 across the card, x from base to tip) minus three round holes, 0 elsewhere;
RGB a green with paler veins (only the metallic-roughness path would use it: the mapped stack
takes its colour from baseColorFactor).

Units: each card is 1 unit long; the stack is thin-walled (no KHR_materials_volume), so the
scene's units do not matter to it.
"""
import base64
import json
import math
import os
import struct
import zlib

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
OUT = os.path.join(ROOT, 'scenes', 'gltf_leaf')
SIZE = 256
HOLES = [(0.35, 0.58, 0.045), (0.55, 0.40, 0.03), (0.68, 0.60, 0.025)]  # (x, v, radius) in UV


def png_rgba(path, w, h, pixels):
    """pixels: bytes of w * h * 4 (rows from the top). A minimal PNG writer (no PIL needed)."""
    raw = b''.join(b'\0' + pixels[y * w * 4:(y + 1) * w * 4] for y in range(h))

    def chunk(tag, data):
        return struct.pack('>I', len(data)) + tag + data + struct.pack('>I', zlib.crc32(tag + data) & 0xffffffff)
    with open(path, 'wb') as f:
        f.write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 6, 0, 0, 0)) +
                chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b''))


def texture():
    px = bytearray(SIZE * SIZE * 4)
    for j in range(SIZE):
        v = (j + 0.5) / SIZE
        for i in range(SIZE):
            x = (i + 0.5) / SIZE  # along the midrib, base (u = 0) to tip (u = 1)
            half = 0.3 * math.sin(math.pi * x) ** 0.7 if 0.0 < x < 1.0 else 0.0
            inside = abs(v - 0.5) < half
            for hx, hv, r in HOLES:
                if (x - hx) ** 2 + (v - hv) ** 2 < r * r:
                    inside = False
            # Veins: the midrib and lateral veins at 50 degrees, 0.012 wide.
            d = abs(v - 0.5)
            # distance (in x) to the nearest of the lateral veins x = d / tan(50 deg) + k / 7
            lateral = abs(((x - d / math.tan(math.radians(50))) * 7.0) % 1.0 - 0.5) / 7.0
            vein = d < 0.008 or (lateral > 1.0 / 14.0 - 0.006 and d < half * 0.9)
            r, g, b = (150, 190, 90) if vein else (60, 120, 30)
            k = 4 * (j * SIZE + i)
            px[k:k + 4] = bytes([r, g, b, 255 if inside else 0])
    png_rgba(os.path.join(OUT, 'leaf_rgba.png'), SIZE, SIZE, bytes(px))


def main():
    os.makedirs(OUT, exist_ok=True)
    texture()
    # One card: x from 0 (base) to 1 (tip), y across (-0.5..0.5), normal +Z; u = x, v = 0.5 - y.
    pos = [0, -0.5, 0, 1, -0.5, 0, 1, 0.5, 0, 0, 0.5, 0]
    nrm = [0, 0, 1] * 4
    uv = [0, 1, 1, 1, 1, 0, 0, 0]
    idx = [0, 1, 2, 0, 2, 3]
    data = struct.pack('12f', *pos) + struct.pack('12f', *nrm) + struct.pack('8f', *uv) + struct.pack('6H', *idx) + b'\0\0'
    with open(os.path.join(OUT, 'gltf_leaf.bin'), 'wb') as f:
        f.write(data)

    def scene(light_dir_node_rotation, name):
        nodes = []
        # Three leaves fanned about the base, each turned a little about its midrib.
        for k, (yaw, roll) in enumerate([(-45, 10), (0, -15), (45, 20)]):
            a, r = math.radians(90 + yaw) / 2, math.radians(roll) / 2
            qz = [0, 0, math.sin(a), math.cos(a)]  # about +Z: the card's +x (the tip) points up-ish
            qx = [math.sin(r), 0, 0, math.cos(r)]  # about the midrib (local x)
            # q = qz * qx (Hamilton product; glTF stores x, y, z, w)
            x1, y1, z1, w1 = qz
            x2, y2, z2, w2 = qx
            q = [w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                 w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2]
            nodes.append({'name': 'leaf%d' % k, 'mesh': 0, 'rotation': q, 'translation': [0.0, -0.55, 0.03 * k]})
        nodes.append({'name': 'view', 'camera': 0, 'translation': [0.0, 0.0, 2.6]})
        nodes.append({'name': 'sun', 'rotation': light_dir_node_rotation, 'extensions': {'KHR_lights_punctual': {'light': 0}}})
        g = {
            'asset': {'version': '2.0', 'generator': 'scripts/make_gltf_leaf_scene.py'},
            'extensionsUsed': ['KHR_lights_punctual', 'KHR_materials_diffuse_transmission'],
            'scene': 0,
            'scenes': [{'nodes': list(range(len(nodes)))}],
            'nodes': nodes,
            'cameras': [{'name': 'view', 'type': 'perspective', 'perspective': {'yfov': 0.6, 'znear': 0.05}}],
            'extensions': {'KHR_lights_punctual': {'lights': [
                {'name': 'sun', 'type': 'directional', 'color': [1.0, 0.98, 0.95], 'intensity': 4.0}]}},
            'meshes': [{'name': 'card', 'primitives': [
                {'attributes': {'POSITION': 0, 'NORMAL': 1, 'TEXCOORD_0': 2}, 'indices': 3, 'material': 0}]}],
            'materials': [{
                'name': 'leaf', 'doubleSided': True, 'alphaMode': 'MASK', 'alphaCutoff': 0.5,
                'pbrMetallicRoughness': {'baseColorFactor': [0.22, 0.42, 0.08, 1.0], 'metallicFactor': 0.0,
                                         'roughnessFactor': 0.6, 'baseColorTexture': {'index': 0}},
                'extensions': {'KHR_materials_diffuse_transmission': {'diffuseTransmissionFactor': 0.45}}}],
            'textures': [{'source': 0, 'sampler': 0}],
            'samplers': [{'wrapS': 33071, 'wrapT': 33071}],
            'images': [{'uri': 'leaf_rgba.png'}],
            'buffers': [{'byteLength': len(data), 'uri': 'gltf_leaf.bin'}],
            'bufferViews': [
                {'buffer': 0, 'byteOffset': 0, 'byteLength': 48},
                {'buffer': 0, 'byteOffset': 48, 'byteLength': 48},
                {'buffer': 0, 'byteOffset': 96, 'byteLength': 32},
                {'buffer': 0, 'byteOffset': 128, 'byteLength': 12},
            ],
            'accessors': [
                {'bufferView': 0, 'componentType': 5126, 'count': 4, 'type': 'VEC3', 'min': [0, -0.5, 0], 'max': [1, 0.5, 0]},
                {'bufferView': 1, 'componentType': 5126, 'count': 4, 'type': 'VEC3'},
                {'bufferView': 2, 'componentType': 5126, 'count': 4, 'type': 'VEC2'},
                {'bufferView': 3, 'componentType': 5123, 'count': 6, 'type': 'SCALAR'},
            ],
        }
        path = os.path.join(OUT, name)
        with open(path, 'w') as f:
            json.dump(g, f, indent=1)
            f.write('\n')
        print(path)

    # A directional light shines down its local -Z. Front: identity (from +Z, the camera's side,
    # tilted 30 degrees down about X); back: turned 180 degrees about Y (from -Z, behind the leaves).
    t = math.radians(-30) / 2
    front = [math.sin(t), 0, 0, math.cos(t)]
    back = [0, math.cos(t), -math.sin(t), 0]  # (180 about Y) * (tilt about X)
    scene(front, 'gltf_leaf_front.gltf')
    scene(back, 'gltf_leaf_back.gltf')


if __name__ == '__main__':
    main()
