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

// The map alone: `relative` (width x height, row-major) in diverging_colour(relative / range),
// as LINEAR values (the display colours decoded from sRGB) ready for write_png or a contact sheet.
Image false_colour_map(const std::vector<float>& relative, int width, int height, double range);

// The map of `relative` (width x height, row-major) scaled so +-range reach full red/blue,
// above a legend strip: caption ("blue: TEST < REF, red: TEST > REF"), the colour bar and
// tick labels at -range, -range/2, 0, +range/2, +range in percent, then the `notes` (say, which
// image is REF and which TEST), each wrapped to the canvas width (text.h's wrap_text) so none is
// cut. Text is rendered with FreeType (text.h) in DejaVu Sans when that font is installed, else
// the tick labels come from a built-in 3x5 bitmap font and the caption and notes are left out.
// The canvas is at least kMinLegendWidth wide; the map sits at its top-left corner; it is
// kLegendHeight taller than the map, plus kLegendNoteLineHeight a note line and
// kLegendNotesMargin when there are notes.
// Returns LINEAR values (the display colours decoded from sRGB), ready for write_png.
constexpr int kMinLegendWidth = 280;
constexpr int kLegendHeight = 56;
constexpr int kLegendNoteLineHeight = 15;
constexpr int kLegendNotesMargin = 4;
// caption: empty for the default "blue: TEST < REF    red: TEST > REF".
Image false_colour_with_legend(const std::vector<float>& relative, int width, int height, double range,
                               const std::string& caption = "", const std::vector<std::string>& notes = {});

// The legend's caption for a difference of images smoothed by a Gaussian of `sigma` pixels
// (image_compare.h's smoothed_pair): "" (the default caption) for 0, else one that names sigma.
std::string difference_caption(double sigma);

// The note lines false_colour_with_legend draws for `notes` on a canvas `canvas_width` wide:
// each wrapped; none without the font.
std::vector<std::string> legend_note_lines(const std::vector<std::string>& notes, int canvas_width);

}  // namespace lamina
