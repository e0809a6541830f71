"""Fitting a slab to measured totals: the absorption and scattering of a 0.5 mm slab from its
reflectance and transmittance at normal incidence (docs/examples/slab_rt.csv, made from
slab_truth.json), starting far off (docs/python.md, "Examples").

    python3 examples/fit_slab.py [--quick] [--out DIR]
"""

import argparse
import json
from pathlib import Path

import lamina

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "docs/examples"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the coarser model (the test suite's size)")
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder of the fitted material (default out/)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    truth = lamina.Stack.load(EXAMPLES / "slab_truth.json")
    r = lamina.fit(EXAMPLES / "slab.json", EXAMPLES / "slab_rt.csv",
                   {"layers[0].sigma_a": (0, 20), "layers[0].sigma_s": (0, 100)},
                   quadrature_points=8 if args.quick else 16)
    print(f"chi2 {r.chi2:.3g} with {r.dof} degrees of freedom")
    for name, true in (("layers[0].sigma_a[r]", truth.layers[0].sigma_a[0]),
                       ("layers[0].sigma_s[r]", truth.layers[0].sigma_s[0])):
        value, sigma = r.values[name], r.sigmas[name]
        print(f"  {name} = {value:.5g} +- {sigma:.2g} /mm (truth {true:g}: {(value - true) / sigma:+.2f} sigma)")
    for w in r.warnings:
        print(f"  warning: {w}")
    # The fitted slab's totals at normal incidence against the measurements.
    check = lamina.brdf(r.stack, 0, method="adding-doubling", table=False)
    print(f"fitted slab: R {check.total('R_specular')[0] + check.total('R_diffuse')[0]:.4f}, "
          f"T {check.total('T_ballistic')[0] + check.total('T_diffuse')[0]:.4f} (measured 0.2129, 0.2756)")
    (args.out / "slab_fitted.json").write_text(json.dumps(r.stack.to_dict(), indent=2) + "\n")
    print(f"wrote {args.out / 'slab_fitted.json'}")


if __name__ == "__main__":
    main()
