#!/usr/bin/env python3
"""Tests of bench/smoothed_bias.py, the face benchmark's smoothed per-pixel bias estimate.

    test_smoothed_bias.py                  synthetic images of known bias and noise (numpy only)
    test_smoothed_bias.py --lamina EXE     also: the Gaussian smoothing gives `lamina compare
                                           --smooth 1`'s figures (needs the lamina Python package
                                           on PYTHONPATH to write the EXRs)

Synthetic images: a truth L (a shaded ball on a black background, its texture varying over a few
pixels), a bias field b (relative, known), and two references and two tested renders of
independent multiplicative gamma noise (mean 1, skewed like a renderer's). The true smoothed bias
B is computed from the noise-free images with the same smoothing. Tolerances are the estimate's
own standard error (3 of them) and, for the standard error itself, the spread over repeated
trials.
Exits 1 naming the failed check.
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench"))
import smoothed_bias as sb  # noqa: E402

FAILURES = []


def check(ok, message):
    print(("ok   " if ok else "FAIL ") + message)
    if not ok:
        FAILURES.append(message)


def truth(h, w):
    """A ball's shading times a fine texture, black outside the ball, per channel."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    r2 = ((x - w / 2) / (0.45 * w)) ** 2 + ((y - h / 2) / (0.45 * h)) ** 2
    inside = r2 < 1
    shade = np.sqrt(np.clip(1 - r2, 0, 1)) + 0.1
    texture = 1 + 0.3 * np.sin(x / 2.3) * np.cos(y / 3.1)
    L = np.stack([shade * texture * c for c in (0.8, 0.5, 0.35)], axis=2)
    L[~inside] = 0
    return L


def bias_field(h, w, amplitude, pattern=True):
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    if not pattern:
        return np.full((h, w, 1), amplitude)
    return (amplitude * np.sin(x / 9.0) * np.cos(y / 13.0) + 0.5 * amplitude * (x > w / 2))[..., None]


def noisy(rng, mean, rel_sd):
    """mean times gamma noise of mean 1 and relative standard deviation rel_sd, per pixel and channel."""
    k = 1.0 / rel_sd ** 2
    return mean * rng.gamma(k, 1.0 / k, size=mean.shape)


def true_bias(L, b, kernel):
    mask = (L > 0).any(axis=2)
    sl = sb.smooth(L, mask, sb.KERNELS[kernel])
    st = sb.smooth(L * (1 + b), mask, sb.KERNELS[kernel])
    den = np.maximum(sl, 0.01 * L.mean())
    return float(np.sqrt((((st - sl) / den) ** 2).mean()))


def old_estimate(refs, tests, kernel):
    """The benchmark's earlier figure: rms(S T1 - S R1)^2 less half rms(S R1 - S R2)^2, relative to
    S R1 (the reference's noise out, the test's in)."""
    r1, r2 = refs
    mask = (r1 > 0).any(axis=2)
    k = sb.KERNELS[kernel]
    sr1, sr2, st1 = (sb.smooth(a, mask, k) for a in (r1, r2, tests[0]))
    den = np.maximum(sr1, 0.01 * r1.mean())
    total = (((st1 - sr1) / den) ** 2).mean()
    ref = (((sr2 - sr1) / den) ** 2).mean() / 2
    return math.sqrt(max(0.0, total - ref))


def trial(rng, L, b, ref_sd, test_sd):
    refs = [noisy(rng, L, ref_sd) for _ in range(2)]
    tests = [noisy(rng, L * (1 + b), test_sd) for _ in range(2)]
    return refs, tests


def test_recovers_known_bias():
    """A 2 % patterned bias under the noise of the face benchmark's renders (smoothed: about 4 %
    for the references and 3 % for the test): the estimate holds within 3 standard errors for
    both kernels; the earlier estimate, which leaves the test's noise in, does not."""
    rng = np.random.default_rng(7)
    h, w = 300, 164
    L, b = truth(h, w), bias_field(h, w, 0.02)
    refs, tests = trial(rng, L, b, 0.15, 0.10)
    for kernel in ("gaussian1", "box5"):
        want = true_bias(L, b, kernel)
        e = sb.smoothed_bias(refs, tests, kernel)
        z = (e["bias_sq"] - want ** 2) / e["bias_sq_se"]
        check(abs(z) < 3, f"{kernel}: B {e['bias']:.4f} +- {e['bias_se']:.4f} against the true {want:.4f} "
                          f"(B^2 off by {z:+.2f} standard errors; test noise {e['test_noise']:.4f}, "
                          f"reference noise {e['reference_noise']:.4f})")
        old = old_estimate(refs, tests, kernel)
        z_old = (old ** 2 - want ** 2) / e["bias_sq_se"]
        check(z_old > 3, f"{kernel}: the earlier estimate {old:.4f} is off by {z_old:+.1f} of the new standard errors")


def test_no_bias_is_zero():
    """Unbiased test renders at the face crop's size: the mean of 8 estimates of B^2 within 3 of
    its standard errors (their spread over sqrt(8)) of 0, and each estimate within 4 of its own."""
    rng = np.random.default_rng(11)
    h, w = 300, 164
    L = truth(h, w)
    for kernel in ("gaussian1", "box5"):
        est, z = [], []
        for _ in range(8):
            e = sb.smoothed_bias(*trial(rng, L, np.zeros((h, w, 1)), 0.15, 0.10), kernel)
            est.append(e["bias_sq"])
            z.append(e["bias_sq"] / e["bias_sq_se"])
        z_mean = np.mean(est) / (np.std(est, ddof=1) / math.sqrt(len(est)))
        check(abs(z_mean) < 3 and max(map(abs, z)) < 4,
              f"{kernel}: no bias: mean B^2 {np.mean(est):.3g} ({z_mean:+.2f} standard errors), "
              f"single estimates {min(z):+.2f} to {max(z):+.2f} of their own")


def test_standard_error_matches_the_spread():
    """Over 24 independent trials of a uniform 1.5 % bias, the block standard error is the spread
    of the estimates: their ratio within [0.6, 1.6] (24 trials know a spread to about 15 %), and
    the mean estimate within 3 standard errors of the mean of the truth."""
    rng = np.random.default_rng(3)
    h, w = 128, 96
    L, b = truth(h, w), bias_field(h, w, 0.015, pattern=False)
    for kernel in ("gaussian1", "box5"):
        est, se = [], []
        for _ in range(24):
            e = sb.smoothed_bias(*trial(rng, L, b, 0.15, 0.10), kernel)
            est.append(e["bias_sq"])
            se.append(e["bias_sq_se"])
        spread, mean_se = float(np.std(est, ddof=1)), float(np.mean(se))
        check(0.6 < mean_se / spread < 1.6, f"{kernel}: block standard error {mean_se:.3g} against the trials' spread {spread:.3g}")
        want = true_bias(L, b, kernel) ** 2
        z = (np.mean(est) - want) / (spread / math.sqrt(len(est)))
        check(abs(z) < 3, f"{kernel}: mean of 24 estimates of B^2 {np.mean(est):.4g} against {want:.4g} ({z:+.2f} standard errors)")


def test_gaussian_is_lamina_compare_smooth(lamina_exe):
    """The Gaussian of sigma 1 over the reference's non-black pixels is `lamina compare --smooth 1`:
    its RMS relative difference of two images equals the command's to float precision."""
    import json

    import lamina

    rng = np.random.default_rng(5)
    h, w = 40, 30
    L = truth(h, w)
    ref, test = noisy(rng, L, 0.2), noisy(rng, L, 0.2)
    with tempfile.TemporaryDirectory() as d:
        paths = [os.path.join(d, n) for n in ("ref.exr", "test.exr")]
        for p, a in zip(paths, (ref, test)):
            lamina.Image(a.astype(np.float32)).write(p)
        out = os.path.join(d, "m.json")
        subprocess.run([lamina_exe, "compare", *paths, "--smooth", "1", "--json", out], check=True, capture_output=True)
        with open(out) as f:
            want = json.load(f)["rms_relative"]
        r, t = (lamina.Image.read(p).rgb.astype(np.float64) for p in paths)
    mask = (r > 0).any(axis=2)
    k = sb.KERNELS["gaussian1"]
    sr, st = sb.smooth(r, mask, k), sb.smooth(t, mask, k)
    got = float(np.sqrt((((st - sr) / np.maximum(sr, 0.01 * sr.mean())) ** 2).mean()))
    check(abs(got - want) < 1e-5 * want, f"smoothed RMS relative difference {got:.7f} against lamina compare's {want:.7f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lamina", help="the lamina executable: also check the smoothing against `lamina compare --smooth`")
    args = ap.parse_args()
    test_recovers_known_bias()
    test_no_bias_is_zero()
    test_standard_error_matches_the_spread()
    if args.lamina:
        test_gaussian_is_lamina_compare_smooth(args.lamina)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
