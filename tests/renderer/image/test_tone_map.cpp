// Tone mapping of PNGs: the properties a display transform must have, each of which a wrong
// curve or matrix breaks.
#include "renderer/image/tone_map.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace lamina {
namespace {

ToneMap filmic(double exposure = 0.0) { return ToneMap{exposure, ToneCurve::Filmic}; }

float mapped_grey(const ToneMap& t, float v) {
  float rgb[3] = {v, v, v};
  tone_map_pixel(t, rgb);
  return rgb[1];
}

TEST(ToneMap, ClampAtZeroExposureIsTheOldClampedPreview) {
  float rgb[3] = {0.25f, 1.5f, -0.5f};
  tone_map_pixel(ToneMap{0.0, ToneCurve::Clamp}, rgb);
  EXPECT_EQ(rgb[0], 0.25f);
  EXPECT_EQ(rgb[1], 1.0f);
  EXPECT_EQ(rgb[2], 0.0f);
}

TEST(ToneMap, ExposureIsAPowerOfTwoBeforeTheCurve) {
  for (ToneCurve curve : {ToneCurve::Clamp, ToneCurve::Filmic})
    for (float v : {0.01f, 0.1f, 0.3f, 2.0f}) {
      float a[3] = {v, 0.5f * v, 0.25f * v}, b[3] = {4.0f * v, 2.0f * v, v};
      tone_map_pixel(ToneMap{2.0, curve}, a);
      tone_map_pixel(ToneMap{0.0, curve}, b);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-6) << tone_curve_name(curve) << " " << v;
    }
}

TEST(ToneMap, FilmicKeepsGreyGreyIsMonotoneAndRollsOffBelowWhite) {
  float previous = 0.0f;
  for (double v = 1e-4; v < 1e4; v *= 1.25) {
    float rgb[3] = {static_cast<float>(v), static_cast<float>(v), static_cast<float>(v)};
    tone_map_pixel(filmic(), rgb);
    EXPECT_NEAR(rgb[0], rgb[1], 2e-5) << v;  // the matrices' rows sum to 1
    EXPECT_NEAR(rgb[2], rgb[1], 2e-5) << v;
    EXPECT_GE(rgb[1], previous) << v;
    EXPECT_LE(rgb[1], 1.0f);
    previous = rgb[1];
  }
  // Highlights: 1 (white in the clamped preview) is still below display white, and a value 100x
  // brighter still separates from it; at 1e4 the curve is at white.
  EXPECT_LT(mapped_grey(filmic(), 1.0f), 0.9f);
  EXPECT_GT(mapped_grey(filmic(), 100.0f), mapped_grey(filmic(), 1.0f) + 0.1f);
  EXPECT_GT(mapped_grey(filmic(), 1e4f), 0.99f);
  // Mid grey 0.18 lands near ACES's ~10 % display value, black stays black.
  EXPECT_NEAR(mapped_grey(filmic(), 0.18f), 0.105f, 0.01f);
  EXPECT_EQ(mapped_grey(filmic(), 0.0f), 0.0f);
}

TEST(ToneMap, FilmicKeepsTheHueOrderOfASaturatedColour) {
  float rgb[3] = {0.8f, 0.3f, 0.1f};
  tone_map_pixel(filmic(), rgb);
  EXPECT_GT(rgb[0], rgb[1]);
  EXPECT_GT(rgb[1], rgb[2]);
}

TEST(ToneMap, NonFiniteRadianceBecomesBlack) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  for (ToneCurve curve : {ToneCurve::Clamp, ToneCurve::Filmic}) {
    float rgb[3] = {nan, inf, -inf};
    tone_map_pixel(ToneMap{0.0, curve}, rgb);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(rgb[c], 0.0f) << tone_curve_name(curve);
  }
}

TEST(ToneMap, CurveNames) {
  ToneCurve c = ToneCurve::Clamp;
  EXPECT_TRUE(parse_tone_curve("filmic", &c));
  EXPECT_EQ(c, ToneCurve::Filmic);
  EXPECT_TRUE(parse_tone_curve("clamp", &c));
  EXPECT_EQ(c, ToneCurve::Clamp);
  EXPECT_FALSE(parse_tone_curve("aces", &c));
}

}  // namespace
}  // namespace lamina
