#!/usr/bin/env python3
"""Writes tests/data/mitsuba_microfacet.csv: Mitsuba 3's rough dielectric and rough conductor
BSDF values at random direction pairs, the independent reference of tests/materials/
test_microfacet_mitsuba.cpp. Run by hand after `pip install mitsuba==3.9.1` (pinned: the values are
data); the test reads only the CSV.

Columns: kind (dielectric | conductor), alpha, ior (dielectric: interior index, exterior 1;
conductor: eta), k (conductor), the viewer direction v (Mitsuba's si.wi), the light direction l
(Mitsuba's wo), Mitsuba's eval in the red channel, which is f(v, l) |l.z| for radiance, and
Mitsuba's masking-shadowing G1(v) G1(l) (separable Smith, the one Mitsuba 3 uses), so the test
can compare everything else with Lamina's height-correlated model.
"""
import csv
import math
import os
import random

import mitsuba as mi

mi.set_variant('scalar_rgb')

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'tests', 'data', 'mitsuba_microfacet.csv')


def unit(rng, lower_allowed):
    while True:
        v = [rng.uniform(-1, 1) for _ in range(3)]
        n = math.sqrt(sum(x * x for x in v))
        if 0.1 < n <= 1.0:
            v = [x / n for x in v]
            if abs(v[2]) < 0.05:
                continue
            if not lower_allowed:
                v[2] = abs(v[2])
            return v


def main():
    rng = random.Random(12)
    rows = []
    ctx = mi.BSDFContext()
    for alpha in (0.1, 0.3, 0.7):
        for ior in (1.33, 1.5):
            bsdf = mi.load_dict({'type': 'roughdielectric', 'distribution': 'ggx', 'alpha': alpha,
                                 'int_ior': ior, 'ext_ior': 1.0, 'sample_visible': True})
            for _ in range(60):
                v, l = unit(rng, True), unit(rng, True)
                si = mi.SurfaceInteraction3f()
                si.wi = mi.Vector3f(v)
                value = bsdf.eval(ctx, si, mi.Vector3f(l))[0]
                rows.append(['dielectric', alpha, ior, 0.0, *v, *l, float(value)])
    for alpha in (0.1, 0.4, 0.9):
        for eta, k in ((0.2, 3.9), (1.5, 0.5)):
            bsdf = mi.load_dict({'type': 'roughconductor', 'distribution': 'ggx', 'alpha': alpha,
                                 'eta': eta, 'k': k, 'sample_visible': True})
            for _ in range(40):
                v, l = unit(rng, False), unit(rng, False)
                si = mi.SurfaceInteraction3f()
                si.wi = mi.Vector3f(v)
                value = bsdf.eval(ctx, si, mi.Vector3f(l))[0]
                rows.append(['conductor', alpha, eta, k, *v, *l, float(value)])
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, 'w', newline='') as f:
        w = csv.writer(f)
        f.write('# Mitsuba %s, scalar_rgb: scripts/mitsuba_reference.py\n' % mi.__version__)
        w.writerow(['kind', 'alpha', 'ior', 'k', 'vx', 'vy', 'vz', 'lx', 'ly', 'lz', 'mitsuba'])
        for r in rows:
            w.writerow([r[0]] + ['%.9g' % x for x in r[1:]])
    print('wrote', OUT, len(rows), 'rows')


if __name__ == '__main__':
    main()
