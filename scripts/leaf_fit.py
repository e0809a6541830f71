#!/usr/bin/env python3
"""Fits the layered leaf (cuticle, palisade, spongy mesophyll; material-file "leaf" layers,
docs/spectral.md, "Layered leaf") to PROSPECT-D's reflectance and transmittance, 400-2500 nm, for
the five leaves of tests/data/prospect_d_reference.csv (prosail 2.0.5; Lamina's own PROSPECT-D
agrees with it within 5e-11), which span the ANGERS leaves' range.

Each leaf's contents (chlorophyll a+b, carotenoids, anthocyanins, brown pigments, water, dry
matter) are PROSPECT's, shared between the palisade (a fitted share of all of them) and the spongy
mesophyll (the rest); the cuticle holds none. The cuticle's top is a diffuse interface
(materials/interfaces/diffuse_interface.h: PROSPECT's plate surface), and so is the leaf's lower
face where that fits better (--interfaces auto: both variants are fitted, the better kept). Four numbers are fitted per leaf: the palisade's
share, the palisade's and the spongy mesophyll's plates (their scattering) and the scattering's
wavelength power b of both; the Henyey-Greenstein g of both is G (only the reduced scattering
matters: g 0.95 to 0.98 at the same reduced scattering moves R and T by at most 0.001). The
model's R and T are `lamina brdf --method adding-doubling --wavelengths` averaged over PROSPECT's
incident cone (isotropic light within 40 degrees: three Gauss-Legendre nodes in sin^2 theta). The fit minimises the squared deviations of
R and T every 10 nm (SciPy's least_squares), then their largest absolute value (Nelder-Mead from
there); the fitted leaf is evaluated at every nanometre, lit on its upper (adaxial) face as
fitted and on its lower (abaxial) face (the same stack seen from below; PROSPECT has no sides, so
that column says how far the layered leaf's two faces differ from the one PROSPECT leaf).

Writes a CSV per leaf (default build/leaf_fit.csv; docs/leaf_fit.csv in the docs), the material
file of the first leaf (--scene, e.g. scenes/spectral/leaf_layered.json), a plot (--plot,
matplotlib) and prints the worst and median largest deviation.

Usage: python3 scripts/leaf_fit.py [--lamina build/renderer/lamina] [--out build/leaf_fit.csv]
                                   [--scene FILE.json] [--plot FILE.png] [--leaves a,b]
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
REFERENCE = os.path.join(ROOT, 'tests', 'data', 'prospect_d_reference.csv')
G = 0.95  # Henyey-Greenstein g of the mesophyll's scattering: forward, as the earlier fits of g all chose
THICKNESS = {'cuticle': 0.003, 'palisade': 0.1, 'spongy': 0.12}  # mm; R and T depend on none of them
QUADRATURE_POINTS = 8
FIT_GRID = '400:2500:10'
CONE_DEGREES = 40.0  # PROSPECT's incident cone (Jacquemoud and Baret 1990)


def cone_nodes():
    """Isotropic radiance within the cone: the irradiance is uniform in u = sin^2 theta."""
    x, w = np.polynomial.legendre.leggauss(3)
    u = np.sin(np.radians(CONE_DEGREES)) ** 2 * (x + 1.0) / 2.0
    return np.degrees(np.arcsin(np.sqrt(u))), w / 2.0


def read_reference():
    lines = open(REFERENCE).read().splitlines()
    leaves = []
    for item in lines[1][len('# leaf: '):].split('; '):
        name, *pairs = item.split()
        leaves.append((name, {k: float(v) for k, v in (p.split('=') for p in pairs)}))
    data = np.array([[float(x) for x in line.split(',')] for line in lines[3:]])
    return leaves, data


# Which of the leaf's two faces are diffuse interfaces (materials/interfaces/diffuse_interface.h,
# PROSPECT's plate surface): 'both', 'top' (the cuticle's alone) or 'smooth' (Fresnel interfaces,
# the earlier model); --interfaces. 'auto', the default, fits 'both' and 'top' and keeps the one
# whose largest deviation is smaller: whether the lower face is diffuse is a fitted choice.
INTERFACES = 'both'


def material(name, leaf, plates_palisade, plates_spongy, power, share, g=G, digits=4, interfaces=None):
    pigments = {'chlorophyll': leaf['cab'], 'carotenoids': leaf['car'], 'anthocyanins': leaf['ant'], 'brown': leaf['brown']}
    volume = {'water': leaf['cw'], 'dry_matter': leaf['cm']}

    share = round(share, digits)

    def layer(fraction, plates):
        out = {k: round(fraction * v, 6) for k, v in {**pigments, **volume}.items() if v > 0}
        out.update({'plates': round(plates, digits), 'scattering_power': round(power, digits), 'g': round(g, digits)})
        return out

    interfaces = interfaces or INTERFACES
    doc = {'lamina_material': 1, 'name': f'leaf_{name}', 'layers': [
        {'name': 'cuticle', 'thickness': THICKNESS['cuticle'], 'leaf': {}},
        {'name': 'palisade', 'thickness': THICKNESS['palisade'], 'leaf': layer(share, plates_palisade)},
        {'name': 'spongy', 'thickness': THICKNESS['spongy'], 'leaf': layer(1 - share, plates_spongy)}]}
    if interfaces in ('top', 'both'):
        doc = {'lamina_material': 1, 'name': doc['name'], 'top_diffuse': True, 'layers': doc['layers']}
    if interfaces == 'both':
        doc['layers'][-1]['bottom_diffuse'] = True
    return doc


def flipped(doc):
    """The same leaf seen from below: layers reversed, the top's diffuse flag and the last layer's
    bottom one swapped (LayerStack's flipped(); the leaf's inner interfaces are index-matched)."""
    layers = [{k: v for k, v in layer.items() if k != 'bottom_diffuse'} for layer in doc['layers'][::-1]]
    out = {k: v for k, v in doc.items() if k not in ('top_diffuse', 'layers')}
    if doc['layers'][-1].get('bottom_diffuse'):
        out['top_diffuse'] = True
    if doc.get('top_diffuse'):
        layers[-1]['bottom_diffuse'] = True
    out['layers'] = layers
    return out


class Model:
    def __init__(self, lamina, points):
        self.lamina, self.points, self.solves = lamina, points, 0
        self.angles, self.weights = cone_nodes()
        self.dir = tempfile.mkdtemp(prefix='leaf_fit_')

    def rt(self, doc, grid, abaxial=False):
        """Cone-averaged R and T of a material document (seen from below if abaxial)."""
        if abaxial:
            doc = flipped(doc)
        path = os.path.join(self.dir, 'leaf.json')
        with open(path, 'w') as f:
            json.dump(doc, f)
        r = t = 0.0
        for angle, weight in zip(self.angles, self.weights):
            out = os.path.join(self.dir, 'out.json')
            subprocess.run([self.lamina, 'brdf', path, '--theta-i', repr(float(angle)), '--method', 'adding-doubling',
                            '--wavelengths', grid, '--quadrature-points', str(self.points), '--summary', out], check=True)
            with open(out) as f:
                d = json.load(f)
            r = r + weight * (np.array(d['R_specular']) + np.array(d['R_diffuse']))
            t = t + weight * (np.array(d['T_ballistic']) + np.array(d['T_diffuse']))
            self.solves += len(d['wavelength_nm'])
        return np.array(d['wavelength_nm']), r, t


def fit_leaf(model, name, leaf, target):
    from scipy.optimize import least_squares, minimize
    # plates of the palisade and of the spongy mesophyll, b, the palisade's share of the contents
    lo, hi = np.array([0.0, 0.0, -2.0, 0.0]), np.array([10.0, 10.0, 2.0, 1.0])

    def residuals(p):
        nm, r, t = model.rt(material(name, leaf, *np.clip(p, lo, hi), digits=12), FIT_GRID)
        ref_r, ref_t = target(nm)
        return np.concatenate([r - ref_r, t - ref_t])

    start = np.array([0.4, max(leaf['N'] - 1.0, 0.2) + 0.5, 0.0, 0.3])
    l2 = least_squares(residuals, start, bounds=(lo, hi), diff_step=1e-3)
    worst = minimize(lambda p: np.abs(residuals(p)).max(), l2.x, method='Nelder-Mead',
                     options={'maxfev': 120, 'xatol': 1e-3, 'fatol': 1e-5, 'initial_simplex': [
                         l2.x, l2.x + [0.05, 0, 0, 0], l2.x + [0, 0.1, 0, 0], l2.x + [0, 0, 0.1, 0],
                         l2.x + [0, 0, 0, 0.05 if l2.x[3] < 0.9 else -0.05]]})
    return np.clip(worst.x, lo, hi)


def deviation(nm, model_values, reference_values):
    d = np.abs(model_values - reference_values)
    k = int(np.argmax(d))
    return float(d[k]), int(nm[k])


def plot(path, rows, curves):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(curves), figsize=(4.2 * len(curves), 3.6), sharey=True)
    for ax, (name, nm, ref_r, ref_t, r, t, r_ab) in zip(np.atleast_1d(axes), curves):
        ax.plot(nm, ref_r, color='k', lw=1.6, label='PROSPECT-D R')
        ax.plot(nm, 1 - ref_t, color='0.45', lw=1.6, label='PROSPECT-D 1 - T')
        ax.plot(nm, r, color='tab:green', lw=0.9, label='layered R (adaxial)')
        ax.plot(nm, 1 - t, color='tab:blue', lw=0.9, label='layered 1 - T')
        ax.plot(nm, r_ab, color='tab:orange', lw=0.8, ls='--', label='layered R (abaxial)')
        row = next(x for x in rows if x['leaf'] == name)
        ax.set_title(f"{name}: N {row['N']}, Cab {row['chlorophyll']}, diffuse faces {row['diffuse_faces']}\nmax |dR| {row['max_dR']:.4f}, "
                     f"max |dT| {row['max_dT']:.4f}", fontsize=9)
        ax.set_xlabel('wavelength (nm)')
        ax.set_xlim(400, 2500)
        ax.set_ylim(0, 1)
    np.atleast_1d(axes)[0].set_ylabel('reflectance, 1 - transmittance')
    np.atleast_1d(axes)[0].legend(fontsize=7, loc='center right')
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    global INTERFACES
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--lamina', default=os.path.join(ROOT, 'build', 'renderer', 'lamina'))
    parser.add_argument('--out', default=os.path.join(ROOT, 'build', 'leaf_fit.csv'))
    parser.add_argument('--scene', help='write the first leaf\'s fitted material file here')
    parser.add_argument('--plot', help='write the measured-against-modelled plot (PNG) here')
    parser.add_argument('--leaves', help='comma-separated names (default: all five)')
    parser.add_argument('--interfaces', choices=('auto', 'both', 'top', 'smooth'), default='auto',
                        help='the diffuse faces: both, the top alone, none (smooth Fresnel interfaces), or auto '
                             '(default: both and top fitted, the better kept)')
    args = parser.parse_args()
    variants = ['both', 'top'] if args.interfaces == 'auto' else [args.interfaces]

    leaves, data = read_reference()
    if args.leaves:
        wanted = args.leaves.split(',')
        unknown = [w for w in wanted if w not in [name for name, _ in leaves]]
        if unknown:
            sys.exit(f'leaf_fit: unknown leaf {unknown[0]} (in {REFERENCE}: {", ".join(n for n, _ in leaves)})')
    model = Model(args.lamina, QUADRATURE_POINTS)
    rows, curves = [], []
    for i, (name, leaf) in enumerate(leaves):
        if args.leaves and name not in wanted:
            continue

        def target(nm, i=i):
            k = np.rint(nm - data[0, 0]).astype(int)
            return data[k, 1 + 2 * i], data[k, 2 + 2 * i]

        t0, solves0 = time.process_time(), model.solves
        children0 = os.times()
        best = None
        for variant in variants:
            INTERFACES = variant
            p = fit_leaf(model, name, leaf, target)
            doc = material(name, leaf, *p)  # rounded as written: evaluated as a user would read it
            nm, r, t = model.rt(doc, '400:2500:1')
            ref_r, ref_t = target(nm)
            worst = max(np.abs(r - ref_r).max(), np.abs(t - ref_t).max())
            if len(variants) > 1:
                print(f'{name}: diffuse faces {variant}: largest deviation {worst:.4f}', flush=True)
            if best is None or worst < best[0]:
                best = (worst, variant, p, doc, nm, r, t)
        _, faces, p, doc, nm, r, t = best
        INTERFACES = faces
        _, r_ab, t_ab = model.rt(doc, '400:2500:1', abaxial=True)
        children1 = os.times()
        cpu = (children1.children_user + children1.children_system - children0.children_user - children0.children_system +
               time.process_time() - t0)
        dr, dr_nm = deviation(nm, r, ref_r)
        dt, dt_nm = deviation(nm, t, ref_t)
        ab_r, _ = deviation(nm, r_ab, ref_r)
        ab_t, _ = deviation(nm, t_ab, ref_t)
        palisade, spongy = doc['layers'][1]['leaf'], doc['layers'][2]['leaf']
        rows.append({'leaf': name, 'N': leaf['N'], 'chlorophyll': leaf['cab'], 'carotenoids': leaf['car'],
                     'anthocyanins': leaf['ant'], 'brown': leaf['brown'], 'water': leaf['cw'], 'dry_matter': leaf['cm'],
                     'diffuse_faces': faces, 'palisade_share': round(p[3], 4), 'plates_palisade': palisade['plates'],
                     'plates_spongy': spongy['plates'], 'g': palisade['g'],
                     'scattering_power': palisade['scattering_power'],
                     'max_dR': round(dr, 4), 'max_dR_nm': dr_nm, 'max_dT': round(dt, 4), 'max_dT_nm': dt_nm,
                     'rmse': round(float(np.sqrt(np.mean(np.concatenate([r - ref_r, t - ref_t]) ** 2))), 4),
                     'abaxial_max_dR': round(ab_r, 4), 'abaxial_max_dT': round(ab_t, 4),
                     'spectra_solved': model.solves - solves0, 'cpu_seconds': round(cpu, 1)})
        print(f"{name}: diffuse faces {faces}, palisade share {p[3]:.4f}, plates {palisade['plates']}, {spongy['plates']}, "
              f"b {palisade['scattering_power']}: max |dR| {dr:.4f} at {dr_nm} nm, "
              f"max |dT| {dt:.4f} at {dt_nm} nm; abaxial {ab_r:.4f}, {ab_t:.4f}", flush=True)
        curves.append((name, nm, ref_r, ref_t, r, t, r_ab))
        if args.scene and len(rows) == 1:  # the first leaf fitted
            with open(args.scene, 'w') as f:
                json.dump(doc, f, indent=2)
                f.write('\n')
    if not rows:
        sys.exit('leaf_fit: no leaf fitted')
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, 'w', newline='') as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    worst = [max(x['max_dR'], x['max_dT']) for x in rows]
    k = int(np.argmax(worst))
    print(f'largest |deviation| per leaf (R or T, adaxial): median {np.median(worst):.4f}, worst {worst[k]:.4f} '
          f'({rows[k]["leaf"]}); within 0.01: {sum(x <= 0.01 for x in worst)} of {len(rows)}')
    if args.plot:
        chosen = [c for c in curves if c[0] in ('mature_green', 'thin_pale', 'thick_dark')] or curves[:3]
        plot(args.plot, rows, chosen)


if __name__ == '__main__':
    main()
