// Text drawn into float RGB images through FreeType: the labels of contact sheets and the
// legends of false-colour pictures. Glyphs are blended by their coverage (anti-aliased), in
// whatever values the image holds.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace lamina {

enum class TextAlign { kLeft, kCentre };

// Width in pixels of `text` set at `pixel_size` (the em height) in the TrueType font at
// `font_path`; -1 if the font cannot be loaded.
int text_width(const std::string& text, int pixel_size, const std::string& font_path);

// Draws `text` on the width x height RGB floats `rgb` (row-major, 3 per pixel) with its baseline
// at row `baseline`, starting at column x (kLeft) or centred on it (kCentre), clipped to the
// image. False, and nothing drawn, if the font cannot be loaded.
bool draw_text(float* rgb, int width, int height, int x, int baseline, const std::string& text, int pixel_size,
               const std::string& font_path, const std::array<float, 3>& colour, TextAlign align = TextAlign::kLeft);

// `text` broken into lines at most `max_width` pixels wide at `pixel_size` in the font, greedily:
// first between the parts of a label (at a space after ',' or '/': "head / base / default,
// 16 spp" keeps "16 spp" together), a part wider than a line at its spaces, and a word wider
// than a line between characters (never inside a UTF-8 sequence). So every character of `text`
// is on some line and none is cut off; the spaces a line breaks at are dropped. A text of only
// spaces gives no lines. If the font cannot be loaded the text is returned as one line.
std::vector<std::string> wrap_text(const std::string& text, int max_width, int pixel_size, const std::string& font_path);

}  // namespace lamina
