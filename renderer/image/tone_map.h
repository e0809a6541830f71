// Tone mapping: from the linear scene radiance of a render to the display-linear values in
// [0, 1] that write_png encodes with the sRGB transfer function. Only PNGs are tone mapped; the
// EXR always keeps the linear radiance (docs/contracts.md, "Tone mapping").
#pragma once

#include <string>

#include "renderer/image/image.h"

namespace lamina {

enum class ToneCurve {
  Clamp,   // display = min(1, exposed): the radiance as it is, highlights clipped
  Filmic,  // the ACES reference rendering and sRGB output transforms, as fitted by Hill (below)
};

struct ToneMap {
  double exposure = 0.0;  // stops: the radiance is multiplied by 2^exposure before the curve
  ToneCurve curve = ToneCurve::Filmic;
};

// "clamp" or "filmic"; false for any other name.
bool parse_tone_curve(const std::string& name, ToneCurve* curve);
const char* tone_curve_name(ToneCurve curve);

// The display-linear value of one linear Rec. 709 radiance (r, g, b), in place; each in [0, 1].
// Non-finite input gives 0 (a NaN never reaches a PNG).
void tone_map_pixel(const ToneMap& tone_map, float* rgb);
// The whole image, ready for write_png.
Image tone_mapped(const Image& linear, const ToneMap& tone_map);

}  // namespace lamina
