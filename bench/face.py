#!/usr/bin/env python3
"""The face benchmark: time to a clean image, and the bias of the fast modes, on the showcase.

    bench/face.py [--lamina build/renderer/lamina] [--out out/face] [--scenes head_skin,leaves_back]
                  [--methods walk,auto] [--tolerance 0.01] [--ref-spp 1024] [--scale 1] [--quick]
                  [--references REF1.exr REF2.exr] [--bias-spp N]

For each scene it renders two long walk references once (kept in OUT/, their file names carry
their settings; only the crop and a 4-pixel margin are rendered; or takes them from
--references, walk renders of the same size, e.g. time-limited ones; their difference measures
the reference's own noise, which every relative RMSE has taken out) and then each method at 1, 2, 4, ... spp until its relative RMSE over the subject (a crop
around the face or the leaves) is below the target (default 5 %) or --max-spp is reached. A
method is `walk` (--subsurface random-walk, the unbiased reference technique) or `auto`
(--subsurface auto --tolerance T: tables, lambert or the walk per material, its precomputation
included). Every number is of one run on this machine, wall-clock seconds of the whole `lamina
render` process (scene loading and tables included); the machine is shared, so read them as an
order of magnitude and compare methods within one run of this script.

Per method it prints and writes to OUT/face.md and OUT/face.csv:
  seconds to the target   interpolated log-log between the two runs around it
  mean bias               mean(method) / mean(reference) - 1 over the crop, at the last run
  smoothed RMS difference `lamina compare --smooth 1` (a Gaussian of sigma 1 pixel) at the last
                          run: the bias and both images' noise together
  smoothed pixel bias     B, the RMS relative bias after smoothing (a Gaussian of sigma 1 pixel,
                          and a 5 x 5 box), with its standard error: two renders of the method
                          (seeds 1 and 2, at --bias-spp, default the last run's spp) against the
                          two references, the noise of both taken out (bench/smoothed_bias.py,
                          which says how). B is 0 where no bias is resolved; read it with its
                          standard error
Python does no image maths for the RMSE and the mean: those come from `lamina compare --json`
(the mean of an image over the crop is its guard floor divided by the guard epsilon); the bias
estimate reads the EXRs with the lamina Python package (built beside the executable,
LAMINA_BUILD_PYTHON) into numpy.
Exits non-zero if a render or a comparison fails.
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from tradeoff import time_to  # noqa: E402 (the speed-accuracy report's log-log interpolation)
from smoothed_bias import smoothed_bias  # noqa: E402 (bench/smoothed_bias.py, beside this file)

# name -> (glTF, extra render arguments, crop as fractions x, y, w, h of the image)
SCENES = {
    "head_skin": ("scenes/head_skin/head_skin.gltf", ["--env", "0.05"], (0.33, 0.13, 0.34, 0.50)),
    "leaves_back": ("scenes/leaves/leaves_back.gltf", [], (0.20, 0.15, 0.60, 0.75)),
}
SIZES = {"head_skin": (480, 600), "leaves_back": (320, 240)}


def fail(message):
    print(f"face.py: {message}", file=sys.stderr)
    sys.exit(1)


def run(cmd):
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"{' '.join(cmd)} failed: {p.stderr.strip() or p.stdout.strip()}")
    return p


def render(args, scene, method, spp, seed, exr, size, region=None, cache=None):
    gltf, extra, _ = SCENES[scene]
    mode = ["--subsurface", "random-walk"] if method == "walk" else \
        ["--subsurface", "auto", "--tolerance", str(args.tolerance)]
    cmd = [args.lamina, "render", gltf, *extra, *mode, "--width", str(size[0]), "--height", str(size[1]),
           "--spp", str(spp), "--seed", str(seed), "--threads", str(args.threads), "-o", exr]
    if region:
        cmd += ["--crop", *map(str, region)]
    if cache:
        cmd += ["--cache", cache]
    t0 = time.monotonic()
    run(cmd)
    return time.monotonic() - t0


def crop_arguments(scene, size):
    fx, fy, fw, fh = SCENES[scene][2]
    w, h = size
    return ["--crop", str(round(fx * w)), str(round(fy * h)), str(max(1, round(fw * w))), str(max(1, round(fh * h)))]


def reference_region(crop, size, margin=4):
    """`lamina render --crop X0 Y0 X1 Y1` of the compared crop (x, y, w, h) and a margin for --smooth."""
    x, y, w, h = (int(v) for v in crop[1:])
    return [max(0, x - margin), max(0, y - margin), min(size[0], x + w + margin), min(size[1], y + h + margin)]


def compare(args, ref, test, crop, smooth=None):
    out = test[:-4] + (f"-smooth{smooth}" if smooth else "") + ".json"
    cmd = [args.lamina, "compare", ref, test, *crop, "--json", out] + (["--smooth", str(smooth)] if smooth else [])
    run(cmd)
    with open(out) as f:
        return json.load(f)


def read_rgb(path):
    """An EXR's RGB as a numpy array (height, width, 3), through the lamina Python package."""
    import lamina
    return lamina.Image.read(path).rgb


def import_lamina(executable):
    """The lamina Python package of the build the executable belongs to (BUILD/python), else
    whatever PYTHONPATH gives."""
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(executable)), "python"))
    try:
        import lamina  # noqa: F401
    except ImportError as e:
        fail(f"the bias estimate reads EXRs with the lamina Python package, not found beside {executable} "
             f"(build it: LAMINA_BUILD_PYTHON=ON, the default; or set PYTHONPATH): {e}")


def bias_estimates(refs, tests, crop):
    """B for the Gaussian of sigma 1 and the 5 x 5 box (bench/smoothed_bias.py) over the crop."""
    r, t = [read_rgb(p) for p in refs], [read_rgb(p) for p in tests]
    box = tuple(int(v) for v in crop[1:])
    return {k: smoothed_bias(r, t, k, crop=box) for k in ("gaussian1", "box5")}


def image_mean(j):
    """The mean of the reference image over the crop: compare's guard floor is epsilon * mean(REF)."""
    return j["guard_floor"] / j["guard_epsilon"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lamina", default=os.path.join(ROOT, "build/renderer/lamina"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out/face"))
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--methods", default="walk,auto")
    ap.add_argument("--tolerance", type=float, default=0.01, help="auto's --tolerance")
    ap.add_argument("--target", type=float, default=0.05, help="relative RMSE target over the crop")
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--max-spp", type=int, default=512)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--scale", type=float, default=1.0, help="image size as a fraction of 480x600 (head) and 320x240 (leaves)")
    ap.add_argument("--quick", action="store_true", help="pipeline check: 1/8 size, reference 16 spp, max 4 spp")
    ap.add_argument("--references", nargs=2, metavar="EXR", help="two walk references of the one scene (instead of rendering them)")
    ap.add_argument("--bias-spp", type=int, default=0,
                    help="spp of the two renders (seeds 1, 2) the smoothed bias is measured on (default: the last run's)")
    args = ap.parse_args()
    args.lamina = os.path.abspath(args.lamina)
    args.out = os.path.abspath(args.out)
    if not os.access(args.lamina, os.X_OK):
        fail(f"{args.lamina}: no lamina executable (build it, or pass --lamina)")
    scenes, methods = args.scenes.split(","), args.methods.split(",")
    for s in scenes:
        if s not in SCENES:
            fail(f"unknown scene {s!r} (known: {', '.join(SCENES)})")
    for m in methods:
        if m not in ("walk", "auto"):
            fail(f"unknown method {m!r} (known: walk, auto)")
    if args.bias_spp < 0:
        fail(f"--bias-spp {args.bias_spp}: must be at least 1 (or 0: the last run's spp)")
    if args.references and len(scenes) != 1:
        fail("--references needs exactly one scene (--scenes)")
    if args.quick:
        args.ref_spp, args.max_spp, args.scale = 16, 4, 0.125
    import_lamina(args.lamina)
    os.makedirs(os.path.join(args.out, "runs"), exist_ok=True)
    results = []
    for scene in scenes:
        size = tuple(max(8, round(v * args.scale)) for v in SIZES[scene])
        crop = crop_arguments(scene, size)
        # Two independent references: the first is the reference, their difference measures its own
        # noise, which is taken out of every comparison (MSE(test, ref) - var(ref), unbiased when
        # the test and the reference are independent), so a short reference does not hide the target.
        refs = [os.path.abspath(r) for r in args.references] if args.references else []
        for k, seed in enumerate((1000, 2000)):
            if args.references:
                break
            ref = os.path.join(args.out, f"ref{k}-{scene}-{size[0]}x{size[1]}-{args.ref_spp}spp-crop.exr")
            if not os.path.exists(ref):
                print(f"{scene}: reference {k + 1} of 2, random-walk {args.ref_spp} spp at {size[0]}x{size[1]} ...", flush=True)
                secs = render(args, scene, "walk", args.ref_spp, seed, ref + ".tmp.exr", size, reference_region(crop, size))
                os.replace(ref + ".tmp.exr", ref)
                print(f"{scene}: reference in {secs:.0f} s", flush=True)
            refs.append(ref)
        ref = refs[0]
        # References and the compared renders hold the region only: the crop relative to it.
        region = reference_region(crop, size)
        crop = ["--crop", str(int(crop[1]) - region[0]), str(int(crop[2]) - region[1]), crop[3], crop[4]]
        ref_var = compare(args, refs[0], refs[1], crop)["rmse"] ** 2 / 2.0
        for method in methods:
            rows, spp = [], 1
            while spp <= args.max_spp:
                # The timed render is the whole image (tables included); the comparison renders
                # the region again, pixel for pixel the same (`lamina render --crop`), reusing the
                # tables from a cache.
                full = os.path.join(args.out, "runs", f"{scene}-{method}-{spp}-full.exr")
                exr = os.path.join(args.out, "runs", f"{scene}-{method}-{spp}.exr")
                secs = render(args, scene, method, spp, 1, full, size)
                render(args, scene, method, spp, 1, exr, size, region, cache=os.path.join(args.out, "cache"))
                j = compare(args, ref, exr, crop)
                self_j = compare(args, exr, exr, crop)
                ref_mean, test_mean = image_mean(j), image_mean(self_j)
                if j["rmse"] ** 2 <= ref_var:
                    # The reference's own noise (estimated from two heavy-tailed renders) hides this
                    # image's error: the measurement ends here, unresolved, not as a target reached.
                    print(f"{scene} {method} {spp} spp: {secs:.1f} s, RMSE {j['rmse']:.4g} within the references' "
                          f"own noise {math.sqrt(ref_var):.4g}: not resolved (a longer --ref-spp would)", flush=True)
                    break
                rows.append(dict(spp=spp, seconds=secs, rel_rmse=math.sqrt(j["rmse"] ** 2 - ref_var) / ref_mean,
                                 mean_bias=test_mean / ref_mean - 1.0, exr=exr))
                print(f"{scene} {method} {spp} spp: {secs:.1f} s, relative RMSE {rows[-1]['rel_rmse']:.4f}, "
                      f"mean {rows[-1]['mean_bias']:+.4f}", flush=True)
                if rows[-1]["rel_rmse"] <= args.target:
                    break
                spp *= 2
            if not rows:
                fail(f"{scene} {method}: already at 1 spp within the references' own noise (a longer --ref-spp would resolve it)")
            smooth = compare(args, ref, rows[-1]["exr"], crop, smooth=1)
            # The bias: two seeds of the method at --bias-spp, the same region and tables.
            bias_spp = args.bias_spp or rows[-1]["spp"]
            tests = []
            for seed in (1, 2):
                exr = os.path.join(args.out, "runs", f"{scene}-{method}-{bias_spp}" + ("" if seed == 1 else f"-seed{seed}") + ".exr")
                if not (seed == 1 and bias_spp == rows[-1]["spp"]):  # else rendered just now
                    render(args, scene, method, bias_spp, seed, exr, size, region, cache=os.path.join(args.out, "cache"))
                tests.append(exr)
            bias = bias_estimates(refs, tests, crop)
            for k, e in bias.items():
                print(f"{scene} {method} {bias_spp} spp x 2 seeds, {k}: smoothed pixel bias {e['bias']:.4f} +- {e['bias_se']:.4f} "
                      f"(RMS difference of the means {e['difference']:.4f}, their smoothed noise: reference "
                      f"{e['reference_noise']:.4f}, test {e['test_noise']:.4f})", flush=True)
            t, _ = time_to([dict(rmse=r["rel_rmse"], seconds=r["seconds"]) for r in rows], args.target)
            g, b = bias["gaussian1"], bias["box5"]
            results.append(dict(scene=scene, method=method, spp=rows[-1]["spp"], seconds=rows[-1]["seconds"],
                                rel_rmse=rows[-1]["rel_rmse"], seconds_to_target=t,
                                mean_bias=rows[-1]["mean_bias"], smoothed_rms_difference=smooth["rms_relative"],
                                bias_spp=bias_spp, smoothed_pixel_bias=g["bias"], smoothed_pixel_bias_se=g["bias_se"],
                                box5_pixel_bias=b["bias"], box5_pixel_bias_se=b["bias_se"],
                                reference_smoothed_noise=g["reference_noise"], test_smoothed_noise=g["test_noise"]))
    with open(os.path.join(args.out, "face.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(results[0]))
        w.writeheader()
        w.writerows(results)
    lines = [f"| scene | method | seconds to {args.target:.0%} relative RMSE | last run: spp, seconds, relative RMSE "
             "| mean bias | smoothed RMS difference | smoothed pixel bias: Gaussian sigma 1, 5 x 5 box (spp x 2 seeds; "
             "smoothed noise of the mean reference, test) |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        t = f"{r['seconds_to_target']:.1f}" if r["seconds_to_target"] is not None else f"not reached by {r['spp']} spp"
        name = r["method"] if r["method"] == "walk" else f"auto --tolerance {args.tolerance:g}"
        lines.append(f"| {r['scene']} | {name} | {t} | {r['spp']}, {r['seconds']:.1f}, {r['rel_rmse']:.4f} "
                     f"| {r['mean_bias']:+.2%} | {r['smoothed_rms_difference']:.2%} "
                     f"| {r['smoothed_pixel_bias']:.2%} +- {r['smoothed_pixel_bias_se']:.2%}, "
                     f"{r['box5_pixel_bias']:.2%} +- {r['box5_pixel_bias_se']:.2%} ({r['bias_spp']} x 2; "
                     f"{r['reference_smoothed_noise']:.2%}, {r['test_smoothed_noise']:.2%}) |")
    with open(os.path.join(args.out, "face.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
