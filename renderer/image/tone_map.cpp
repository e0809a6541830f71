#include "renderer/image/tone_map.h"

#include <algorithm>
#include <cmath>

namespace lamina {

bool parse_tone_curve(const std::string& name, ToneCurve* curve) {
  if (name == "clamp") *curve = ToneCurve::Clamp;
  else if (name == "filmic") *curve = ToneCurve::Filmic;
  else return false;
  return true;
}

const char* tone_curve_name(ToneCurve curve) { return curve == ToneCurve::Clamp ? "clamp" : "filmic"; }

namespace {

// The ACES 1.0 reference rendering transform followed by the sRGB (Rec. 709, 100 nit) output
// transform, as fitted by Stephen Hill ("ACESFitted", BakingLab, 2016): linear Rec. 709 goes
// to the ACES working space AP1 with the RRT's saturation change folded in (kInput), a rational
// fit of the RRT and ODT tone scale is applied per channel (rrt_odt_fit), and kOutput folds the
// ODT's desaturation, AP1 -> XYZ, the D60 -> D65 adaptation and XYZ -> Rec. 709. Every row of
// both matrices sums to 1 (to 1e-5), so grey stays grey. The curve maps scene grey 0.18 to about
// 0.105 display-linear (ACES puts mid grey at ~10 % of the display's white) and approaches 1 for
// large values, so highlights roll off instead of clipping.
constexpr double kInput[3][3] = {{0.59719, 0.35458, 0.04823}, {0.07600, 0.90834, 0.01566}, {0.02840, 0.13383, 0.83777}};
constexpr double kOutput[3][3] = {{1.60475, -0.53108, -0.07367}, {-0.10208, 1.10813, -0.00605}, {-0.00327, -0.07276, 1.07602}};

double rrt_odt_fit(double v) {
  const double a = v * (v + 0.0245786) - 0.000090537;
  const double b = v * (0.983729 * v + 0.4329510) + 0.238081;
  return a / b;
}

float unit(double v) { return static_cast<float>(std::clamp(v, 0.0, 1.0)); }

}  // namespace

void tone_map_pixel(const ToneMap& tone_map, float* rgb) {
  const double scale = std::exp2(tone_map.exposure);
  double c[3];
  for (int k = 0; k < 3; ++k) {
    const double v = static_cast<double>(rgb[k]) * scale;
    c[k] = std::isfinite(v) ? std::max(v, 0.0) : 0.0;
  }
  if (tone_map.curve == ToneCurve::Clamp) {
    for (int k = 0; k < 3; ++k) rgb[k] = unit(c[k]);
    return;
  }
  double ap1[3];
  for (int r = 0; r < 3; ++r) ap1[r] = rrt_odt_fit(kInput[r][0] * c[0] + kInput[r][1] * c[1] + kInput[r][2] * c[2]);
  for (int r = 0; r < 3; ++r) rgb[r] = unit(kOutput[r][0] * ap1[0] + kOutput[r][1] * ap1[1] + kOutput[r][2] * ap1[2]);
}

Image tone_mapped(const Image& linear, const ToneMap& tone_map) {
  Image out = linear;
  for (std::size_t i = 0; i + 2 < out.rgb.size(); i += 3) tone_map_pixel(tone_map, &out.rgb[i]);
  return out;
}

}  // namespace lamina
