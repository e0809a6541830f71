"""A parameter sweep: the skin preset's dermal blood fraction from 0.005 to 0.05, each rendered on
the sphere scene and compared with the preset (blood 0.02), in a grid of images and relative
differences (docs/python.md, "Examples").

    python3 examples/blood_sweep.py [--quick] [--out DIR]
"""

import argparse
import copy
import json
from pathlib import Path

import numpy as np

import lamina

HERE = Path(__file__).resolve().parent
FRACTIONS = (0.005, 0.01, 0.02, 0.05)


def with_blood(base: dict, fraction: float) -> lamina.Stack:
    """The dermis (layers[1]) with `fraction` of blood (components[0]) and the rest of its
    components rescaled to keep the sum 1 (as lamina batch's "renormalise")."""
    d = copy.deepcopy(base)
    parts = d["layers"][1]["components"]
    rest = sum(c["fraction"] for c in parts[1:])
    parts[0]["fraction"] = fraction
    for c in parts[1:]:
        c["fraction"] *= (1.0 - fraction) / rest
    return lamina.Stack.from_dict(d, source=f"skin, blood {fraction}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small images, few samples (the test suite's size)")
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder of the figure (default out/)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    size = dict(width=48, height=36, spp=4) if args.quick else dict(width=320, height=240, spp=64)

    base = json.loads((HERE.parent / "scenes/materials/skin.json").read_text())
    scene = HERE.parent / "scenes/spheres/spheres_0.gltf"
    images = {f: lamina.render(scene, materials={"skin": with_blood(base, f)}, seed=1, **size) for f in FRACTIONS}
    reference = images[0.02]
    rows = []
    for f, im in images.items():
        m = lamina.compare(reference, im)
        rows.append((f, m["mean_relative"], m["rms_relative"]))
        print(f"blood {f:<6} mean relative difference to 0.02: {m['mean_relative']:+.4f}, RMS {m['rms_relative']:.4f}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(FRACTIONS), figsize=(3 * len(FRACTIONS), 5))
    for i, (f, im) in enumerate(images.items()):
        display = np.clip(im.rgb / max(np.percentile(reference.rgb, 99), 1e-6), 0, 1) ** (1 / 2.2)
        axes[0, i].imshow(display)
        axes[0, i].set_title(f"blood {f}")
        axes[1, i].imshow(lamina.relative_difference(reference, im), cmap="RdBu_r", vmin=-0.5, vmax=0.5)
        axes[1, i].set_title(f"vs 0.02: {rows[i][1]:+.3f}")
        for ax in axes[:, i]:
            ax.axis("off")
    fig.tight_layout()
    fig.savefig(args.out / "blood_sweep.png", dpi=100)
    print(f"wrote {args.out / 'blood_sweep.png'}")


if __name__ == "__main__":
    main()
