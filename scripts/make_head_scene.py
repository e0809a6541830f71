#!/usr/bin/env python3
"""Writes scenes/lee_perry_smith_head/head_lit.gltf: the textured head of the shared assets with a
camera ("portrait"), a point key light and a directional rim light (KHR_lights_punctual) added to
scene 0. Geometry, material and textures are untouched (same LeePerrySmith_textured.bin and JPEGs)."""
import json
import math
import os

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'scenes', 'lee_perry_smith_head')


def normalize(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def look_at_quat(eye, target, up=(0.0, 1.0, 0.0)):
    """glTF rotation (x, y, z, w) turning local -Z towards target and local +Y towards up."""
    f = normalize([t - e for t, e in zip(target, eye)])
    r = normalize(cross(f, up))
    u = cross(r, f)
    m = [[r[i], u[i], -f[i]] for i in range(3)]  # columns: the local axes in world space
    w = math.sqrt(max(0.0, 1.0 + m[0][0] + m[1][1] + m[2][2])) / 2.0
    return [(m[2][1] - m[1][2]) / (4 * w), (m[0][2] - m[2][0]) / (4 * w), (m[1][0] - m[0][1]) / (4 * w), w]


def add_portrait_rig(j, eye, target, key_position, key_color, key_intensity, rim_from, rim_intensity):
    """Adds to scene 0 of the glTF dict j a camera "portrait" at eye looking at target, a point key
    light and a directional rim light shining from rim_from towards the origin (KHR_lights_punctual).
    Intensities are radiometric (W/sr, W/m^2; see renderer/scene/scene_gltf.h)."""
    j['cameras'] = [{'name': 'portrait', 'type': 'perspective', 'perspective': {'yfov': 0.75, 'znear': 0.1}}]
    j['extensionsUsed'] = ['KHR_lights_punctual']
    j['extensions'] = {'KHR_lights_punctual': {'lights': [
        {'name': 'key', 'type': 'point', 'color': list(key_color), 'intensity': key_intensity},
        {'name': 'rim', 'type': 'directional', 'color': [0.9, 0.95, 1.0], 'intensity': rim_intensity}]}}
    n = len(j['nodes'])
    j['nodes'] += [
        {'name': 'portrait', 'camera': 0, 'translation': list(eye), 'rotation': look_at_quat(eye, target)},
        {'name': 'key', 'translation': list(key_position), 'extensions': {'KHR_lights_punctual': {'light': 0}}},
        {'name': 'rim', 'rotation': look_at_quat(rim_from, (0.0, 0.0, 0.0)),
         'extensions': {'KHR_lights_punctual': {'light': 1}}}]
    j['scenes'][0]['nodes'] += [n, n + 1, n + 2]


def main():
    j = json.load(open(os.path.join(HERE, 'LeePerrySmith_textured.gltf')))
    j['asset'].setdefault('extras', {})['lamina'] = (
        'Lamina demo wrapper of LeePerrySmith_textured.gltf: adds a camera and two lights; '
        'geometry, material and textures unchanged.')
    # The key light at ~11 units gives irradiance ~ 400/121 ~ 3.3 on the face.
    add_portrait_rig(j, eye=(3.0, 1.5, 11.0), target=(0.0, 0.5, 0.0), key_position=(7.0, 6.0, 8.0),
                     key_color=(1.0, 0.95, 0.9), key_intensity=400.0, rim_from=(-3.0, 4.0, -6.0),
                     rim_intensity=1.5)
    with open(os.path.join(HERE, 'head_lit.gltf'), 'w') as f:
        json.dump(j, f, indent=1)
        f.write('\n')


if __name__ == '__main__':
    main()
