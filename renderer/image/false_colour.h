// False-colour pictures of signed relative differences, with a legend drawn into the image,
// for `lamina compare --png`.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "renderer/image/image.h"

namespace lamina {

// Diverging map in display (sRGB-encoded) values: t = +1 red (1,0,0), 0 white, -1 blue
// (0,0,1), linear in between; t is clamped to [-1, 1]; NaN gives mid grey.
std::array<float, 3> diverging_colour(double t);

// The map of `relative` (width x height, row-major) scaled so +-range reach full red/blue,
// above a legend strip: caption ("blue: TEST < REF, red: TEST > REF"), the colour bar and
// tick labels at -range, -range/2, 0, +range/2, +range in percent. Text is rendered with
// FreeType (text.h) in DejaVu Sans when that font is installed, else the
// tick labels come from a built-in 3x5 bitmap font and the caption is left out.
// The canvas is at least kMinLegendWidth wide; the map sits at its top-left corner.
// Returns LINEAR values (the display colours decoded from sRGB), ready for write_png.
constexpr int kMinLegendWidth = 280;
constexpr int kLegendHeight = 56;
// caption: empty for the default "blue: TEST < REF    red: TEST > REF".
Image false_colour_with_legend(const std::vector<float>& relative, int width, int height, double range,
                               const std::string& caption = "");

}  // namespace lamina
