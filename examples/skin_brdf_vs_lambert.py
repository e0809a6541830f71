"""A skin BRDF against Lambert: the layered model's reflection of the skin preset for light at
45 degrees, beside the Lambert lobe of the same diffuse albedo (docs/python.md, "Examples").

    python3 examples/skin_brdf_vs_lambert.py [--quick] [--out DIR]
"""

import argparse
import math
from pathlib import Path

import numpy as np

import lamina

HERE = Path(__file__).resolve().parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer photons (the test suite's size)")
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder of the figure (default out/)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    skin = lamina.Stack.load(HERE.parent / "scenes/materials/skin.json")
    r = lamina.brdf(skin, 45, samples=20000 if args.quick else 1000000, seed=1)
    albedo = r.total("R_diffuse")
    lambert = albedo / math.pi  # the Lambert BRDF of the same albedo, 1/sr
    reflect = r.value[0]        # (bins_theta, bins_phi, 3)
    # The ring nearest the normal and the one nearest grazing, averaged over azimuth.
    near, grazing = int(np.argmin(r.theta_o_deg)), int(np.argmax(r.theta_o_deg))
    print(f"skin, light at 45 deg: R_diffuse {np.round(albedo, 4).tolist()} +- {np.round(r.totals['R_diffuse']['stderr'], 4).tolist()}")
    for name, k in (("near the normal", near), ("near grazing", grazing)):
        ratio = reflect[k].mean(axis=0) / lambert
        print(f"  BRDF / Lambert {name} (theta_o {r.theta_o_deg[k]:.1f} deg): {np.round(ratio, 3).tolist()}")
    lamina.plot_brdf(r, args.out / "skin_brdf.png", title="skin preset against Lambert, light at 45 deg")
    print(f"wrote {args.out / 'skin_brdf.png'}")


if __name__ == "__main__":
    main()
