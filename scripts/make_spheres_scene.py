#!/usr/bin/env python3
"""Writes scenes/spheres/spheres_{0,45}.gltf: the Bevy UV sphere (sphere.bin, MIT OR Apache-2.0)
with a skin stack bound through extras (lamina.stack), a camera on +Z and a directional light at
0 or 45 degrees from the viewing direction (the paper's figure: Lambert against layered)."""
import json, math, os, sys

here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "spheres")
src = json.load(open(os.path.join("/work/shared/assets/sphere", "sphere.gltf"))) if len(sys.argv) < 2 else json.load(open(sys.argv[1]))

for angle in (0, 45):
    g = json.loads(json.dumps(src))
    g["asset"]["generator"] = "scripts/make_spheres_scene.py (sphere from the Bevy project, MIT OR Apache-2.0)"
    g["buffers"][0]["uri"] = "sphere.bin"
    g["materials"] = [{"name": "skin", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0},
                       "extras": {"lamina": {"stack": "../materials/skin.json"}}}]
    g["meshes"][0]["primitives"][0]["material"] = 0
    h = math.radians(angle) / 2.0
    g["cameras"] = [{"name": "front", "type": "perspective", "perspective": {"yfov": math.radians(34.0), "znear": 0.1, "aspectRatio": 1.0}}]
    g["nodes"] = [
        {"mesh": 0, "name": "Sphere"},
        {"name": "front", "camera": 0, "translation": [0.0, 0.0, 4.0]},
        # KHR_lights_punctual: light travels along the node's -Z; rotated about +Y by `angle`.
        {"name": "sun", "rotation": [0.0, math.sin(h), 0.0, math.cos(h)], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]
    g["scenes"] = [{"name": "Scene", "nodes": [0, 1, 2]}]
    g["extensionsUsed"] = ["KHR_lights_punctual"]
    g["extensions"] = {"KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "color": [1, 1, 1], "intensity": 3.0}]}}
    with open(os.path.join(here, "spheres_%d.gltf" % angle), "w") as f:
        json.dump(g, f, indent=1)
