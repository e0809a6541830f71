#!/usr/bin/env python3
"""Checks the floor plan of docs/architecture.md: each folder uses only the folders below it.

Layers, bottom first: the concept folders of materials/ (pure physics: base, spectral,
interfaces, phase, stack, analytic, walk, brdf, adding_doubling, tables, fit), then
renderer/util, image, scene, surfaces, layered, render, batch, cli. Two independent checks:
  1. includes: every `#include "materials/<folder>/..."` or `#include "renderer/<folder>/..."` in
     materials/ and renderer/ names its own folder or one below it (materials/ names nothing of
     renderer/, and no Embree, image-library or tinygltf header);
  2. link graph (with --build DIR): `cmake --graphviz` of the configured build, each
     lamina_<folder> library (lamina_materials_<folder> for materials/) links only libraries of
     folders below it.
Prints every violation as FILE:LINE: message and exits 1 if there is one.
usage: scripts/check_layers.py [--source DIR] [--build DIR]
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

MATERIALS = ["base", "spectral", "interfaces", "phase", "stack", "analytic", "walk", "brdf", "adding_doubling", "tables", "fit"]
RENDERER = ["util", "image", "scene", "surfaces", "layered", "render", "batch", "cli"]
LAYERS = ["materials/" + m for m in MATERIALS] + RENDERER
RANK = {name: i for i, name in enumerate(LAYERS)}
# Third-party headers that materials/ must not see (it is testable alone, without a renderer).
FORBIDDEN_IN_MATERIALS = ("embree", "OpenImageIO", "OpenEXR", "stb_image", "png.h", "ft2build", "tiny_gltf", "tinygltf")


def folder_of(path):
    """The layer of a repository path such as renderer/scene/camera.h, or None."""
    parts = path.split("/")
    if parts[0] == "materials":
        return "materials/" + parts[1] if len(parts) > 2 and "materials/" + parts[1] in RANK else None
    if parts[0] == "renderer" and len(parts) > 2 and parts[1] in RANK:
        return parts[1]
    return None


def check_includes(source):
    problems = []
    for top in ("materials", "renderer"):
        for root, _, files in os.walk(os.path.join(source, top)):
            for name in files:
                if not name.endswith((".h", ".cpp")):
                    continue
                path = os.path.relpath(os.path.join(root, name), source)
                here = folder_of(path)
                if here is None:
                    problems.append(f"{path}:1: not in a layer folder ({', '.join(LAYERS)})")
                    continue
                in_materials = here.startswith("materials/")
                with open(os.path.join(source, path), encoding="utf-8") as f:
                    for number, line in enumerate(f, 1):
                        m = re.match(r'\s*#\s*include\s*[<"]([^>"]+)[>"]', line)
                        if not m:
                            continue
                        target = m.group(1)
                        if in_materials and any(t in target for t in FORBIDDEN_IN_MATERIALS):
                            problems.append(f"{path}:{number}: materials/ includes {target}")
                        if target.startswith("renderer/") and in_materials:
                            problems.append(f"{path}:{number}: materials/ includes {target}")
                            continue
                        there = folder_of(target)
                        if target.startswith(("renderer/", "materials/")) and there is None:
                            problems.append(f"{path}:{number}: {target} is not in a layer folder")
                        elif there is not None and RANK[there] > RANK[here]:
                            problems.append(f"{path}:{number}: {here}/ includes {target}, a layer above it")
    return problems


def library(layer):
    """The CMake library of a layer: lamina_materials_walk, lamina_scene, ..."""
    return "lamina_" + layer.replace("/", "_")


def check_links(build):
    problems = []
    with tempfile.TemporaryDirectory() as tmp:
        dot = os.path.join(tmp, "graph.dot")
        subprocess.run(["cmake", f"--graphviz={dot}", "."], cwd=build, check=True,
                       stdout=subprocess.DEVNULL)
        with open(dot, encoding="utf-8") as f:
            text = f.read()
    names = dict(re.findall(r'"(node\d+)"\s*\[\s*label\s*=\s*"([^"]+)"', text))
    edges = re.findall(r'"(node\d+)"\s*->\s*"(node\d+)"', text)
    layer_of = {}
    for node, label in names.items():
        m = re.fullmatch(r"lamina_materials_(\w+)", label)
        name = "materials/" + m.group(1) if m else label[len("lamina_"):] if label.startswith("lamina_") else None
        if name in RANK:
            layer_of[node] = name
    if len(set(layer_of.values())) < len(LAYERS) - 1:  # cli is the executable `lamina`
        problems.append(f"{build}: the link graph has only {sorted(set(layer_of.values()))}")
    for a, b in edges:
        if a in layer_of and b in layer_of and RANK[layer_of[b]] >= RANK[layer_of[a]]:
            problems.append(f"{build}: {library(layer_of[a])} links {library(layer_of[b])}, not below it")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument("--source", default=os.path.dirname(here))
    parser.add_argument("--build", help="a configured CMake build directory: also check the link graph")
    args = parser.parse_args()
    problems = check_includes(args.source)
    if args.build:
        problems += check_links(args.build)
    for p in problems:
        print(p)
    if problems:
        print(f"check_layers: {len(problems)} violation(s)")
        return 1
    print("check_layers: every include and link goes downwards (" + " < ".join(LAYERS) + ")")
    return 0


if __name__ == "__main__":
    sys.exit(main())
