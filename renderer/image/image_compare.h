// Comparing two renders of the same view: per-pixel relative difference, error metrics and
// SSIM. Used by `lamina compare` (renderer/cli/compare.cpp) and the batch tool.
#pragma once

#include <string>
#include <vector>

#include "renderer/image/image.h"

namespace lamina {

// The relative difference is (TEST - REF) / max(REF, floor) per pixel and channel, with
//   floor = epsilon * mean(REF)   (mean over all pixels and channels),
// so where the reference is near zero the difference is measured against a small fraction of
// the image's typical brightness instead of blowing up; where both are zero it is 0. If the
// reference is entirely black, floor = kBlackReferenceFloor (an absolute radiance).
constexpr double kDefaultGuardEpsilon = 0.01;
constexpr double kBlackReferenceFloor = 1e-6;
double relative_guard_floor(const Image& reference, double epsilon = kDefaultGuardEpsilon);

// Per channel. Sizes must match (std::invalid_argument otherwise).
Image relative_difference(const Image& reference, const Image& test, double floor);

// Rec. 709 luminance of each pixel: one float a pixel, row-major.
std::vector<float> luminance(const Image& image);

// The relative difference of Rec. 709 luminance, one float a pixel, guarded as above with the
// floor taken from the reference's luminance: what `lamina compare --png` shows.
std::vector<float> relative_luminance_difference(const Image& reference, const Image& test,
                                                 double epsilon = kDefaultGuardEpsilon);

struct CompareMetrics {
  double guard_floor = 0.0;
  // Over every pixel and channel (all pixels count, including black ones where both images
  // are zero and the relative difference is 0).
  double mean_relative = 0.0;  // signed: > 0 when TEST is brighter on average
  double rms_relative = 0.0;
  double max_abs_relative = 0.0;
  double mae = 0.0;   // mean |TEST - REF|
  double mse = 0.0;   // mean (TEST - REF)^2
  double rmse = 0.0;  // sqrt(mse)
  double ssim = 1.0;  // ssim_luminance
};

// Throws std::invalid_argument if sizes differ.
CompareMetrics compare_images(const Image& reference, const Image& test, double epsilon = kDefaultGuardEpsilon);

// Mean structural similarity (Wang, Bovik, Sheikh and Simoncelli, "Image quality assessment:
// from error visibility to structural similarity", IEEE TIP 13(4), 2004) of the luminances as
// displayed: the sRGB-encoded Rec. 709 luminance of each image clamped to [0, 1], dynamic
// range L = 1, K1 = 0.01, K2 = 0.03, an 11 x 11 Gaussian window of sigma 1.5 (the paper's
// choices). At the borders the window is cut to the image and renormalised, so every pixel
// counts and images smaller than the window still work. 1 for identical images.
double ssim_luminance(const Image& reference, const Image& test);

// The image smoothed by a Gaussian of standard deviation `sigma` pixels (truncated at 3 sigma),
// averaging only over the pixels where `mask` (the reference) is not black and renormalising the
// weights, so that a silhouette does not mix the background into the object; pixels where the
// mask is black are kept as they are. `lamina compare --smooth`: a difference of two noisy
// renders shows its pattern, not its noise (the legend says so). Sizes must match.
Image smooth_over_mask(const Image& image, const Image& mask, double sigma);

// What `lamina compare --smooth SIGMA` and `lamina batch`'s difference pictures compare: both
// images smoothed by smooth_over_mask with the reference as the mask; sigma 0 leaves them as they
// are. Sigma is in [0, kMaxSmoothSigma] (std::invalid_argument otherwise).
constexpr double kMaxSmoothSigma = 64.0;
struct ImagePair {
  Image reference, test;
};
ImagePair smoothed_pair(const Image& reference, const Image& test, double sigma);

// The w x h region at (x, y); throws std::invalid_argument if it is not inside the image.
Image crop(const Image& image, int x, int y, int w, int h);

}  // namespace lamina
