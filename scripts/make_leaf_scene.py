#!/usr/bin/env python3
"""Writes scenes/leaf/leaf_quad.gltf: a 4 x 4 cm square "leaf" (glTF material "leaf",
double-sided) in the z = 0 plane, facing +Z, lit by a directional light shining down -Z onto its
front (KHR_lights_punctual, 3 W/m^2), with two cameras: "front" on the lit side (light reflected
by the leaf) and "back" behind it (light transmitted through it). Units: centimetres."""
import base64
import json
import os
import struct

positions = [-2, -2, 0, 2, -2, 0, 2, 2, 0, -2, 2, 0]
normals = [0, 0, 1] * 4
indices = [0, 1, 2, 0, 2, 3]
data = struct.pack("12f", *positions) + struct.pack("12f", *normals) + struct.pack("6H", *indices) + b"\0\0"
gltf = {
    "asset": {"version": "2.0", "generator": "scripts/make_leaf_scene.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "intensity": 3.0}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [
        {"name": "leaf", "mesh": 0},
        {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}}},  # shines down -Z
        {"name": "front", "camera": 0, "translation": [0, 0, 8]},
        # 180 degrees about +Y: looks down +Z, at the unlit back of the leaf.
        {"name": "back", "camera": 1, "translation": [0, 0, -8], "rotation": [0, 1, 0, 0]},
    ],
    "cameras": [
        {"name": "front", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.1}},
        {"name": "back", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.1}},
    ],
    "meshes": [{"name": "leaf", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"name": "leaf", "doubleSided": True,
                   "pbrMetallicRoughness": {"baseColorFactor": [0.25, 0.45, 0.1, 1.0], "metallicFactor": 0.0}}],
    "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 48},
        {"buffer": 0, "byteOffset": 48, "byteLength": 48},
        {"buffer": 0, "byteOffset": 96, "byteLength": 12},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-2, -2, 0], "max": [2, 2, 0]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ],
}
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "leaf", "leaf_quad.gltf")
with open(out, "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
print(out)
