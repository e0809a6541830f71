#!/usr/bin/env python3
"""Writes scenes/metal_dielectric/metal_dielectric.gltf: glTF metallic-roughness spheres, a row of
gold metals and a row of red dielectrics at roughness 0.05, 0.25, 0.5, 0.75, 1.0, on a grey ground
disc, lit by a key directional light and a point light (scenes/README.md). The sphere is the Bevy
UV sphere of ../spheres/sphere.bin (MIT OR Apache-2.0), referenced, not copied."""
import json
import math
import os

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'scenes', 'metal_dielectric')
SPHERES = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'scenes', 'spheres', 'spheres_0.gltf')


def main():
    src = json.load(open(SPHERES))
    g = {'asset': {'version': '2.0', 'generator': 'scripts/make_metal_dielectric_scene.py (sphere from the Bevy project, MIT OR Apache-2.0)'}}
    g['buffers'] = [dict(src['buffers'][0], uri='../spheres/sphere.bin')]
    g['bufferViews'] = src['bufferViews']
    g['accessors'] = src['accessors']
    roughness = [0.05, 0.25, 0.5, 0.75, 1.0]
    materials, meshes, nodes = [], [], []
    prim = src['meshes'][0]['primitives'][0]
    for row, (kind, colour, metallic) in enumerate([('gold', [1.0, 0.71, 0.29], 1.0), ('red plastic', [0.6, 0.05, 0.04], 0.0)]):
        for i, r in enumerate(roughness):
            materials.append({'name': '%s %.2f' % (kind, r),
                              'pbrMetallicRoughness': {'baseColorFactor': colour + [1.0], 'metallicFactor': metallic,
                                                       'roughnessFactor': r}})
            meshes.append({'name': materials[-1]['name'], 'primitives': [dict(prim, material=len(materials) - 1)]})
            nodes.append({'name': materials[-1]['name'], 'mesh': len(meshes) - 1,
                          'translation': [2.3 * (i - 2), 1.0, -1.6 + 3.2 * row], 'scale': [0.95, 0.95, 0.95]})
    materials.append({'name': 'ground', 'pbrMetallicRoughness': {'baseColorFactor': [0.35, 0.35, 0.35, 1.0],
                                                                 'metallicFactor': 0.0, 'roughnessFactor': 0.9}})
    meshes.append({'name': 'ground', 'primitives': [dict(prim, material=len(materials) - 1)]})
    nodes.append({'name': 'ground', 'mesh': len(meshes) - 1, 'translation': [0.0, -0.02, 0.0], 'scale': [30.0, 0.02, 30.0]})
    g['materials'], g['meshes'] = materials, meshes
    g['cameras'] = [{'name': 'front', 'type': 'perspective',
                     'perspective': {'yfov': math.radians(30.0), 'znear': 0.1, 'aspectRatio': 1.6}}]
    # Camera at (0, 8, 12) looking at (0, 0.8, 0): rotation about +X by -atan(7.2 / 12).
    pitch = -math.atan2(7.2, 12.0)
    nodes.append({'name': 'front', 'camera': 0, 'translation': [0.0, 8.0, 12.0],
                  'rotation': [math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]})
    # Key: a directional light from the upper left front; light travels along the node's -Z.
    yaw, tilt = math.radians(-35.0), math.radians(-50.0)
    qy = [0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)]
    qx = [math.sin(tilt / 2), 0.0, 0.0, math.cos(tilt / 2)]
    q = [qy[3] * qx[0] + qy[0] * qx[3] + qy[1] * qx[2] - qy[2] * qx[1],
         qy[3] * qx[1] - qy[0] * qx[2] + qy[1] * qx[3] + qy[2] * qx[0],
         qy[3] * qx[2] + qy[0] * qx[1] - qy[1] * qx[0] + qy[2] * qx[3],
         qy[3] * qx[3] - qy[0] * qx[0] - qy[1] * qx[1] - qy[2] * qx[2]]
    nodes.append({'name': 'key', 'rotation': q, 'extensions': {'KHR_lights_punctual': {'light': 0}}})
    nodes.append({'name': 'fill', 'translation': [6.0, 5.0, 6.0], 'extensions': {'KHR_lights_punctual': {'light': 1}}})
    g['nodes'] = nodes
    g['scenes'] = [{'name': 'Scene', 'nodes': list(range(len(nodes)))}]
    g['scene'] = 0
    g['extensionsUsed'] = ['KHR_lights_punctual']
    g['extensions'] = {'KHR_lights_punctual': {'lights': [
        {'name': 'key', 'type': 'directional', 'color': [1.0, 0.97, 0.92], 'intensity': 3.0},
        {'name': 'fill', 'type': 'point', 'color': [0.8, 0.9, 1.0], 'intensity': 60.0}]}}
    os.makedirs(HERE, exist_ok=True)
    with open(os.path.join(HERE, 'metal_dielectric.gltf'), 'w') as f:
        json.dump(g, f, indent=1)
        f.write('\n')


if __name__ == '__main__':
    main()
