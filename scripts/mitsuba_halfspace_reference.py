#!/usr/bin/env python3
"""Writes tests/data/mitsuba_rough_halfspace.csv: Mitsuba 3.9.1's volumetric path tracer on a
rough-coated scattering half-space, the full-transport reference of
tests/materials/walk/test_rough_stack.cpp (RoughStack.MatchesMitsubaVolpath).

The half-space is a box 200 x 200 x 100 (top face z = 0) with a roughdielectric boundary (GGX,
alpha, interior index 1.4) around a homogeneous medium (sigma_t 10 /mm, albedo 0.8, HG g 0.5);
a directional light of unit irradiance arrives from theta_i in the xz plane, and an orthographic
camera looks straight down at the middle of the top face. The pixel radiance is
L = f(wi -> +z) cos(theta_i), glossy reflection included. Each row is one (alpha, theta_i):
the mean over 8 independent renders and its standard error, once with Mitsuba's visible-normal
sampling of the boundary and once with its classic normal sampling. The two estimate the same
BSDF and should agree; they differ by up to ~3 % (Mitsuba 3.9.1 itself), which bounds how
closely this reference can check Lamina.
"""
import csv
import math
import os

import mitsuba as mi
import numpy as np

mi.set_variant('scalar_rgb')
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'tests', 'data', 'mitsuba_rough_halfspace.csv')


def render(alpha, theta, seed, visible):
    t = math.radians(theta)
    scene = mi.load_dict({
        'type': 'scene',
        'integrator': {'type': 'volpath', 'max_depth': -1, 'rr_depth': 100000},
        'sensor': {'type': 'orthographic',
                   'to_world': mi.ScalarTransform4f().look_at(origin=[0, 0, 10], target=[0, 0, 0], up=[0, 1, 0]) @
                   mi.ScalarTransform4f().scale([0.5, 0.5, 1]),
                   'film': {'type': 'hdrfilm', 'width': 8, 'height': 8, 'rfilter': {'type': 'box'}},
                   'sampler': {'type': 'independent', 'sample_count': 2048, 'seed': seed}},
        'light': {'type': 'directional', 'direction': [-math.sin(t), 0.0, -math.cos(t)], 'irradiance': 1.0},
        'slab': {'type': 'cube',
                 'to_world': mi.ScalarTransform4f().translate([0, 0, -100]) @ mi.ScalarTransform4f().scale([200, 200, 100]),
                 'bsdf': {'type': 'roughdielectric', 'distribution': 'ggx', 'alpha': alpha, 'int_ior': 1.4,
                          'ext_ior': 1.0, 'sample_visible': visible},
                 'interior': {'type': 'homogeneous', 'sigma_t': 10.0, 'albedo': 0.8,
                              'phase': {'type': 'hg', 'g': 0.5}}},
    })
    img = np.array(mi.render(scene))
    return float(img[:, :, 0].mean())


def main():
    rows = []
    for alpha in (0.1, 0.3):
        for theta in (0.0, 45.0):
            row = [alpha, theta]
            for visible in (True, False):
                samples = [render(alpha, theta, seed, visible) for seed in range(8)]
                mean = sum(samples) / len(samples)
                se = math.sqrt(sum((s - mean) ** 2 for s in samples) / (len(samples) - 1) / len(samples))
                row += [mean, se]
            rows.append(tuple(row))
            print(*row, flush=True)
    with open(OUT, 'w', newline='') as f:
        f.write('# Mitsuba %s scalar_rgb volpath: scripts/mitsuba_halfspace_reference.py\n' % mi.__version__)
        w = csv.writer(f)
        w.writerow(['alpha', 'theta_i', 'radiance_visible', 'stderr_visible', 'radiance_classic', 'stderr_classic'])
        for r in rows:
            w.writerow(['%.9g' % x for x in r])


if __name__ == '__main__':
    main()
