// Image comparison maths: metrics against hand-computed values, the guard, SSIM identities.
#include "renderer/image/image_compare.h"

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <gtest/gtest.h>

#include "renderer/image/false_colour.h"

namespace lamina {
namespace {

Image grey(int w, int h, std::initializer_list<float> values) {
  Image image(w, h);
  std::size_t i = 0;
  for (float v : values) {
    image.rgb[3 * i] = image.rgb[3 * i + 1] = image.rgb[3 * i + 2] = v;
    ++i;
  }
  return image;
}

TEST(ImageCompare, MetricsMatchHandComputedValues) {
  // REF = 1 everywhere, TEST = 1.5, 0.5, 1.0, 1.2: relative = +0.5, -0.5, 0, +0.2 in each
  // channel, so mean = 0.2/4 = 0.05, mean square = (0.25 + 0.25 + 0 + 0.04)/4 = 0.135; the
  // absolute differences are the same numbers (REF = 1): MAE = 1.2/4 = 0.3, MSE = 0.135.
  const Image ref = grey(2, 2, {1, 1, 1, 1}), test = grey(2, 2, {1.5f, 0.5f, 1.0f, 1.2f});
  const CompareMetrics m = compare_images(ref, test);
  EXPECT_NEAR(m.mean_relative, 0.05, 1e-7);
  EXPECT_NEAR(m.rms_relative, std::sqrt(0.135), 1e-7);
  EXPECT_NEAR(m.max_abs_relative, 0.5, 1e-7);
  EXPECT_NEAR(m.mae, 0.3, 1e-7);
  EXPECT_NEAR(m.mse, 0.135, 1e-7);
  EXPECT_NEAR(m.rmse, std::sqrt(0.135), 1e-7);
  EXPECT_NEAR(m.guard_floor, 0.01, 1e-9);
  EXPECT_LT(m.ssim, 1.0);
}

TEST(ImageCompare, GuardDividesByAFractionOfTheMeanWhereTheReferenceIsDark) {
  // mean(REF) = 2, floor = 0.01 * 2 = 0.02. Pixel 0: REF 0, TEST 0.01 -> 0.01/0.02 = 0.5.
  // Pixel 1: REF 0.01 < floor -> (0.03 - 0.01)/0.02 = 1. Pixel 2: REF 2 > floor -> plain.
  // Pixel 3: both zero -> 0.
  const Image ref = grey(4, 1, {0.0f, 0.01f, 2.0f, 5.99f}), test = grey(4, 1, {0.01f, 0.03f, 3.0f, 5.99f});
  const double floor = relative_guard_floor(ref);
  EXPECT_NEAR(floor, 0.02, 1e-9);
  const Image rel = relative_difference(ref, test, floor);
  EXPECT_NEAR(rel.pixel(0, 0)[0], 0.5, 1e-6);
  EXPECT_NEAR(rel.pixel(1, 0)[1], 1.0, 1e-6);
  EXPECT_NEAR(rel.pixel(2, 0)[2], 0.5, 1e-6);
  EXPECT_EQ(rel.pixel(3, 0)[0], 0.0f);
  // A black reference falls back to the absolute floor; black against black is 0, not NaN.
  const Image black = grey(2, 1, {0, 0});
  EXPECT_EQ(relative_guard_floor(black), kBlackReferenceFloor);
  const CompareMetrics m = compare_images(black, black);
  EXPECT_EQ(m.rms_relative, 0.0);
  EXPECT_TRUE(std::isfinite(m.ssim));
}

TEST(ImageCompare, LuminanceDifferenceUsesRec709WeightsAndTheGuard) {
  // REF grey 1 and 0; TEST (2, 1, 1) brighter in red only: Y = 1 + 0.2126, relative +0.2126.
  // Second pixel: REF 0, TEST (0, 0, 1): Y = 0.0722, floor = 0.01 * mean(Y_ref) = 0.005.
  Image ref(2, 1), test(2, 1);
  ref.pixel(0, 0)[0] = ref.pixel(0, 0)[1] = ref.pixel(0, 0)[2] = 1.0f;
  test.pixel(0, 0)[0] = 2.0f, test.pixel(0, 0)[1] = test.pixel(0, 0)[2] = 1.0f;
  test.pixel(1, 0)[2] = 1.0f;
  const std::vector<float> rel = relative_luminance_difference(ref, test);
  EXPECT_NEAR(rel[0], 0.2126, 1e-6);
  EXPECT_NEAR(rel[1], 0.0722 / 0.005, 1e-4);
}

TEST(ImageCompare, SsimIdentities) {
  Image a(20, 15);
  for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] = 0.5f + 0.4f * std::sin(0.37f * i);
  EXPECT_NEAR(ssim_luminance(a, a), 1.0, 1e-12);
  // Constant images have zero variance, so SSIM = (2 x y + C1) / (x^2 + y^2 + C1) with x, y
  // the sRGB-encoded luminances (eq. 13 with sigma = 0): linear 0.2 -> 0.48453, 1 -> 1.
  const Image dark = grey(3, 3, {0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f});
  const Image white = grey(3, 3, {1, 1, 1, 1, 1, 1, 1, 1, 1});
  const double x = 1.055 * std::pow(0.2, 1.0 / 2.4) - 0.055, y = 1.0, c1 = 1e-4;
  EXPECT_NEAR(ssim_luminance(dark, white), (2 * x * y + c1) / (x * x + y * y + c1), 1e-6);
  EXPECT_THROW(ssim_luminance(a, dark), std::invalid_argument);
  EXPECT_THROW(compare_images(a, dark), std::invalid_argument);
}

TEST(ImageCompare, CropTakesTheRegionAndRejectsOutside) {
  Image a(4, 3);
  for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] = static_cast<float>(i);
  const Image c = crop(a, 1, 1, 2, 2);
  ASSERT_EQ(c.width, 2);
  EXPECT_EQ(c.pixel(0, 0)[0], a.pixel(1, 1)[0]);
  EXPECT_EQ(c.pixel(1, 1)[2], a.pixel(2, 2)[2]);
  EXPECT_THROW(crop(a, 3, 0, 2, 1), std::invalid_argument);
  EXPECT_THROW(crop(a, 0, 0, 0, 1), std::invalid_argument);
  EXPECT_THROW(crop(a, -1, 0, 1, 1), std::invalid_argument);
}

TEST(FalseColour, RedBrighterBlueDarkerWhiteEqual) {
  EXPECT_EQ(diverging_colour(1.0), (std::array<float, 3>{1, 0, 0}));
  EXPECT_EQ(diverging_colour(7.0), (std::array<float, 3>{1, 0, 0}));  // clamped
  EXPECT_EQ(diverging_colour(-1.0), (std::array<float, 3>{0, 0, 1}));
  EXPECT_EQ(diverging_colour(0.0), (std::array<float, 3>{1, 1, 1}));
  EXPECT_EQ(diverging_colour(0.5), (std::array<float, 3>{1, 0.5f, 0.5f}));
  const Image picture = false_colour_with_legend({0.25f, -0.25f}, 2, 1, 0.5);
  EXPECT_EQ(picture.width, kMinLegendWidth);
  EXPECT_EQ(picture.height, 1 + kLegendHeight);
}

// --smooth: a Gaussian over the reference's non-black pixels. A disc of value 1 on black stays
// exactly 1 up to its edge (the background is not mixed in) and the background stays 0; white
// noise on the disc keeps its mean and loses variance by the kernel's factor
// sum w^2 / (sum w)^2 (about 1 / (4 pi sigma^2) inside), checked within 15 % in the interior.
TEST(ImageCompare, SmoothOverMaskKeepsEdgesAndAveragesNoise) {
  const int n = 64;
  Image disc(n, n), noisy(n, n);
  std::uint64_t state = 12345;
  auto uniform = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const bool in = (x - 32) * (x - 32) + (y - 32) * (y - 32) < 28 * 28;
      for (int c = 0; c < 3; ++c) {
        disc.pixel(x, y)[c] = in ? 1.0f : 0.0f;
        noisy.pixel(x, y)[c] = in ? static_cast<float>(1.0 + (uniform() - 0.5) * std::sqrt(12.0)) : 0.0f;
      }
    }
  const double sigma = 2.0;
  const Image flat = smooth_over_mask(disc, disc, sigma);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) EXPECT_FLOAT_EQ(flat.pixel(x, y)[0], disc.pixel(x, y)[0]) << x << "," << y;
  const Image smooth = smooth_over_mask(noisy, disc, sigma);
  double sum = 0.0, sum2 = 0.0, count = 0.0;
  for (int y = 20; y < 44; ++y)
    for (int x = 20; x < 44; ++x) {
      const double v = smooth.pixel(x, y)[1];
      sum += v;
      sum2 += v * v;
      ++count;
    }
  const double mean = sum / count, var = sum2 / count - mean * mean;
  double w1 = 0.0, w2 = 0.0;
  for (int dy = -6; dy <= 6; ++dy)
    for (int dx = -6; dx <= 6; ++dx) {
      const double w = std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma));
      w1 += w;
      w2 += w * w;
    }
  EXPECT_NEAR(mean, 1.0, 0.05);
  EXPECT_NEAR(var, w2 / (w1 * w1), 0.15 * w2 / (w1 * w1));
  EXPECT_THROW(smooth_over_mask(noisy, Image(3, 3), sigma), std::invalid_argument);
}

// The pair `lamina compare --smooth` and `lamina batch`'s difference pictures compare: both
// smoothed with the reference (not the test) as the mask; sigma 0 leaves them as they are.
TEST(ImageCompare, SmoothedPairMasksBothByTheReference) {
  Image ref(8, 8), test(8, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) {
        ref.pixel(x, y)[c] = x < 4 ? 0.0f : 1.0f + 0.1f * ((x + y) % 3);
        test.pixel(x, y)[c] = 0.5f + 0.2f * ((x * 3 + y) % 5);  // non-black everywhere
      }
  const ImagePair same = smoothed_pair(ref, test, 0.0);
  EXPECT_EQ(same.reference.rgb, ref.rgb);
  EXPECT_EQ(same.test.rgb, test.rgb);
  const ImagePair s = smoothed_pair(ref, test, 1.5);
  EXPECT_EQ(s.reference.rgb, smooth_over_mask(ref, ref, 1.5).rgb);
  EXPECT_EQ(s.test.rgb, smooth_over_mask(test, ref, 1.5).rgb);
  EXPECT_NE(s.test.rgb, smooth_over_mask(test, test, 1.5).rgb);  // the test's own mask would differ
  EXPECT_NO_THROW(smoothed_pair(ref, test, kMaxSmoothSigma));
  for (double bad : {-1.0, kMaxSmoothSigma * 1.01, std::nan("")}) EXPECT_THROW(smoothed_pair(ref, test, bad), std::invalid_argument);
}

}  // namespace
}  // namespace lamina
