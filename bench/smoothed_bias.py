"""The smoothed per-pixel bias of a render against a noisy reference, its noise taken out.

The face benchmark (bench/face.py) asks how far a fast mode's image is from the walk's where the
noise is gone: the RMS over pixels of the relative bias after smoothing (a Gaussian of sigma 1 px
or a 5 x 5 box). Both the reference and the tested render are noisy; with two independent renders
of each (seeds), the noise of both is taken out:

  c1, c2 two smoothed references (S R: unbiased for the smoothed truth S L), a1, a2 two smoothed
  renders of the tested mode (mean S L + S b), all independent, S the smoothing (linear). Then
      E[(a1 - c1)(a2 - c2)] = E[a1 - c1] E[a2 - c2] = (S b)^2
  pixel by pixel, whatever the noise's distribution; the estimate averages this and the other
  pairing (a1 - c2)(a2 - c1). With one common denominator it is algebraically the squared
  difference of the means, (t - r)^2 with t = (a1 + a2)/2, r = (c1 + c2)/2, less the mean
  images' own noise, (c1 - c2)^2/4 and (a1 - a2)^2/4: the reference's and the test's smoothed
  noise variances, measured from the two seeds and subtracted.
  Relative: each difference is divided by a denominator from the other pair, D(a, c) = w a +
  (1 - w) c (guarded as `lamina compare` guards, at epsilon times the smoothed reference's mean),
  with w = v_c / (v_a + v_c) from the relative variances of one smoothed render of each kind over
  the crop: this D is uncorrelated with the difference a - c, so the noisy denominator adds no
  term in (bias x variance). Dividing by the noisy reference alone would add 4 b Var(r) / L^2 to
  each pixel's estimate (+27 % of B^2 at a uniform 1.5 % bias under the test's noise levels).
  What remains is of order 3 Var(D) / D^2 relative (under 0.2 % of B^2 here), and the estimand
  is the bias relative to a weighted mean of truth and test, which differs from the bias relative
  to the truth by a factor 1 + w b (a 2 % bias reads 1.96-2.00 %).
Averaged over pixels and channels this estimates B^2, the mean squared smoothed relative bias; B
is reported (0 when the estimate of B^2 is negative: no bias resolved).

Its standard error: neighbouring pixels share the smoothing kernel's samples, so the per-pixel
estimates are correlated over a few pixels; the estimate's variance is taken from means over
square blocks (default 16 px, twice the kernel's 7 px support) treated as independent (a ratio
estimator where the edge blocks are smaller). The blocks' spread also holds how the bias itself
varies over the image, so the standard error is, if anything, too large. The error of B is that
of B^2 over 2B.

The benchmark's earlier estimate, sqrt(rms(S T1 - S R1)^2 - rms(S R1 - S R2)^2 / 2), takes out
the reference's noise but not the tested render's own, so it is biased upwards by that noise
(tests/scripts/test_smoothed_bias.py shows it failing where this one holds).

The smoothing is `lamina compare --smooth`'s (renderer/image/image_compare.h, smooth_over_mask):
only over the reference's non-black pixels, weights renormalised, black pixels kept as they are,
the Gaussian truncated at 3 sigma; the test checks that the Gaussian here gives the command's
figures on the same images.
"""

import numpy as np

# name -> one-dimensional separable kernel (odd length, centred)
KERNELS = {
    "gaussian1": np.exp(-0.5 * np.arange(-3, 4, dtype=np.float64) ** 2),  # sigma 1, radius ceil(3 sigma)
    "box5": np.ones(5),
}


def _convolve_rows_cols(a, kernel):
    """Separable convolution of a (H, W) or (H, W, C) array with zero padding outside."""
    r = len(kernel) // 2
    out = a
    for axis in (0, 1):
        pad = [(0, 0)] * out.ndim
        pad[axis] = (r, r)
        p = np.pad(out, pad)
        n = out.shape[axis]
        acc = np.zeros_like(out)
        for k, w in enumerate(kernel):
            acc += w * np.take(p, np.arange(k, k + n), axis=axis)
        out = acc
    return out


def smooth(image, mask, kernel):
    """image (H, W, 3) smoothed over the pixels where mask (H, W) is true, renormalised; pixels
    outside the mask keep their values (smooth_over_mask in renderer/image/image_compare.cpp)."""
    m = mask.astype(np.float64)
    num = _convolve_rows_cols(image.astype(np.float64) * m[..., None], kernel)
    den = _convolve_rows_cols(m, kernel)
    out = image.astype(np.float64).copy()
    out[mask] = num[mask] / den[mask][:, None]
    return out


def block_mean(q, block):
    """Mean of q (H, W) and its standard error from block means (blocks of block x block pixels,
    the edge ones smaller; a ratio estimator weighted by the pixels in each block)."""
    h, w = q.shape
    sums, counts = [], []
    for y in range(0, h, block):
        for x in range(0, w, block):
            b = q[y:y + block, x:x + block]
            sums.append(b.sum())
            counts.append(b.size)
    sums, counts = np.array(sums), np.array(counts, dtype=np.float64)
    mean = sums.sum() / counts.sum()
    n = len(sums)
    if n < 2:
        return mean, float("inf")
    var = n / (n - 1) * np.sum((sums - mean * counts) ** 2) / counts.sum() ** 2
    return mean, float(np.sqrt(var))


def smoothed_bias(refs, tests, kernel="gaussian1", epsilon=0.01, block=16, crop=None):
    """The smoothed relative bias of the tests' mean against the references' mean.

    refs, tests: two (H, W, 3) arrays each, independent renders (different seeds) of the same
    view; crop (x, y, w, h): the pixels measured, smoothed with their neighbours outside it (the
    whole image by default). Returns a dict: bias (B, the RMS smoothed relative bias, 0 when the estimate of B^2 is
    negative), bias_sq and bias_sq_se (its estimate of B^2 and standard error), bias_se, and the
    parts as RMS relative values: difference (of the two means), reference_noise and test_noise
    (each mean image's own smoothed noise)."""
    k = KERNELS[kernel]
    r1, r2 = (np.asarray(a, dtype=np.float64) for a in refs)
    t1, t2 = (np.asarray(a, dtype=np.float64) for a in tests)
    for a in (r2, t1, t2):
        if a.shape != r1.shape:
            raise ValueError(f"image sizes differ: {r1.shape} and {a.shape}")
    r_mean = 0.5 * (r1 + r2)
    mask = (r_mean > 0).any(axis=2)
    c1, c2, a1, a2 = (smooth(a, mask, k) for a in (r1, r2, t1, t2))
    if crop is not None:
        cx, cy, cw, ch = crop
        c1, c2, a1, a2 = (a[cy:cy + ch, cx:cx + cw] for a in (c1, c2, a1, a2))
    r, t = 0.5 * (c1 + c2), 0.5 * (a1 + a2)
    floor = epsilon * r.mean() if r.mean() > 0 else 1e-6  # lamina compare's guard, of the smoothed reference
    # Relative variances of one smoothed render of each kind, over the crop: the weight w makes
    # the denominator w a + (1 - w) c uncorrelated with the difference a - c.
    inside = r > floor
    v_ref = float(np.mean(((c1 - c2)[inside] / r[inside]) ** 2) / 2.0)
    v_test = float(np.mean(((a1 - a2)[inside] / r[inside]) ** 2) / 2.0)
    w = v_ref / (v_ref + v_test) if v_ref + v_test > 0 else 0.5

    def den(a, c):
        return np.maximum(w * a + (1.0 - w) * c, floor)

    q = 0.5 * ((a1 - c1) * (a2 - c2) / (den(a2, c2) * den(a1, c1)) +
               (a1 - c2) * (a2 - c1) / (den(a2, c1) * den(a1, c2))).mean(axis=2)
    b2, se2 = block_mean(q, block)
    b = float(np.sqrt(max(b2, 0.0)))
    d = den(t, r)
    diff = ((t - r) / d) ** 2
    ref_noise = ((c1 - c2) / (2.0 * d)) ** 2
    test_noise = ((a1 - a2) / (2.0 * d)) ** 2
    return dict(kernel=kernel, bias=b, bias_sq=float(b2), bias_sq_se=se2,
                bias_se=se2 / (2.0 * b) if b > 0 else float(np.sqrt(se2)),
                difference=float(np.sqrt(diff.mean())), reference_noise=float(np.sqrt(ref_noise.mean())),
                test_noise=float(np.sqrt(test_noise.mean())))
