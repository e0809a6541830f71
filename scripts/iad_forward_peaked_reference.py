#!/usr/bin/env python3
"""Writes tests/data/iad_forward_peaked_reference.csv: total reflection and transmission of
forward-peaked slabs (g = 0.9 to 0.999) by iadpython (Prahl's adding-doubling in Python; pinned in
scripts/setup_references.sh) at normal incidence and 60 degrees, the reference of
tests/materials/adding_doubling/test_forward_peaked.cpp.

iadpython 0.5.3's rt() refuses oblique incidence ("cone not implemented yet": it returns zero
matrices when nu_0 != 1), but its quadrature already puts the refracted incidence on a node
(update_quadrature, "case 3/4": Radau ends at nu_0 inside the slab), and the layer and boundary
matrices depend only on the nodes. So the oblique totals are the column of that node, summed
with the same weights as iadpython's UX1_and_UXU sums the normal-incidence column (the last
node, nu = 1). Two checks in this script: the oblique quadrature's diffuse totals (uru, utu)
equal the normal-incidence quadrature's within iadpython's own convergence, and so does the
oblique column read at an incidence of 1e-9 degrees.

Each value is at 48 points for the slab of index 1.4 and 24 for the index-matched one
(iadpython loses precision beyond: at 64 its mismatched totals move by 1e-3, and its matched
normal-incidence rule, Radau on [0, 1], breaks down from ~32 points; see iad_reference.py); the
column `*_unc` is the difference from half those points, iadpython's own discretisation error
bound (its delta-M order is its number of points, so at g = 0.999 it is far from converged).
Columns: name, n, sigma_a, sigma_s, g, thickness (mm), theta_i (deg), ur1, ut1, uru, utu and
their _unc. Usage: scripts/setup_references.sh; python3 scripts/iad_forward_peaked_reference.py
"""
import csv
import math
import os

import numpy as np
import iadpython

IADPYTHON = '0.5.3'
ORDERS = {False: (48, 24), True: (24, 12)}  # by index-matched
# name, albedo a, optical thickness b, g, slab index (air above and below)
CASES = [('n14_b10_g%s' % str(g).replace('0.', ''), 0.99, 10.0, g, 1.4) for g in (0.9, 0.95, 0.99, 0.999)]
CASES += [('n1_b2_g%s' % str(g).replace('0.', ''), 0.9, 2.0, g, 1.0) for g in (0.9, 0.99, 0.999)]
ANGLES = (0.0, 60.0)


def matrices(s):
    """rt_matrices without its refusal of oblique incidence (slab between air, no slides)."""
    R12, T12 = iadpython.simple_layer_matrices(s)
    if s.n == 1:
        return R12, T12
    R01, R10, T01, T10 = iadpython.start.boundary_layer(s, top=True)
    return iadpython.add_same_slides(s, R01, R10, T01, T10, R12, T12)


def totals(a, b, g, n, theta, q):
    s = iadpython.Sample(a=a, b=b, g=g, n=n, quad_pts=q)
    s.nu_0 = math.cos(math.radians(theta)) if theta > 0 else 1.0
    s.update_quadrature()
    R, T = matrices(s)
    nu_c = s.nu_c()
    k = np.min(np.where(s.nu > nu_c))
    nu_in = iadpython.fresnel.cos_snell(1.0, s.nu_0, n)
    j = int(np.argmin(np.abs(s.nu - nu_in)))
    assert abs(s.nu[j] - nu_in) < 1e-12, (s.nu[j], nu_in)
    URx = np.dot(s.twonuw[k:], R[k:, k:])
    UTx = np.dot(s.twonuw[k:], T[k:, k:])
    URU = np.dot(s.twonuw[k:], URx) * s.n ** 2
    UTU = np.dot(s.twonuw[k:], UTx) * s.n ** 2
    return [float(URx[j - k]), float(UTx[j - k]), float(URU), float(UTU)]


def main():
    from importlib.metadata import version
    if version('iadpython') != IADPYTHON:
        raise SystemExit('iad_forward_peaked_reference.py: needs iadpython %s (scripts/setup_references.sh), found %s'
                         % (IADPYTHON, version('iadpython')))
    here = os.path.dirname(os.path.abspath(__file__))
    out = os.path.join(here, '..', 'tests', 'data', 'iad_forward_peaked_reference.csv')
    rows = []
    for name, a, b, g, n in CASES:
        for theta in ANGLES:
            order, coarse = ORDERS[n == 1.0]
            v = totals(a, b, g, n, theta, order)
            c = totals(a, b, g, n, theta, coarse)
            unc = [abs(x - y) for x, y in zip(v, c)]
            if theta > 0:  # the checks of the docstring
                normal = iadpython.Sample(a=a, b=b, g=g, n=n, quad_pts=order).rt()
                grazing0 = totals(a, b, g, n, 1e-9, order)
                for i in (2, 3):
                    assert abs(v[i] - normal[i]) <= unc[i] + 1e-4, (name, i, v[i], normal[i])
                for i in range(4):
                    assert abs(grazing0[i] - normal[i]) <= unc[i] + 1e-4, (name, i, grazing0[i], normal[i])
            rows.append([name, n, repr((1 - a) * b), repr(a * b), g, 1.0, theta] +
                        ['%.8f' % x for x in v] + ['%.2e' % x for x in unc])
    with open(out, 'w', newline='') as f:
        w = csv.writer(f, lineterminator='\n')
        w.writerow(['name', 'n', 'sigma_a', 'sigma_s', 'g', 'thickness', 'theta_i', 'ur1', 'ut1', 'uru', 'utu',
                    'ur1_unc', 'ut1_unc', 'uru_unc', 'utu_unc'])
        w.writerows(rows)
    print('wrote', os.path.normpath(out))


if __name__ == '__main__':
    main()
