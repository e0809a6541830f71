// False-colour difference pictures (see false_colour.h).
#include "renderer/image/false_colour.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "renderer/image/image_io.h"
#include "renderer/image/text.h"

namespace lamina {
namespace {

// Fonts tried in order; the system DejaVu (Debian fonts-dejavu-core) first.
const char* const kFonts[] = {"/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
                              "/usr/share/fonts/TTF/DejaVuSans.ttf"};

// A 3x5 bitmap font for the tick labels when no TrueType font is available: five rows of
// three bits each (most significant bit = left column).
struct Glyph {
  char c;
  unsigned char rows[5];
};
constexpr Glyph kGlyphs[] = {
    {'0', {7, 5, 5, 5, 7}}, {'1', {2, 6, 2, 2, 7}}, {'2', {7, 1, 7, 4, 7}}, {'3', {7, 1, 7, 1, 7}},
    {'4', {5, 5, 7, 1, 1}}, {'5', {7, 4, 7, 1, 7}}, {'6', {7, 4, 7, 5, 7}}, {'7', {7, 1, 1, 1, 1}},
    {'8', {7, 5, 7, 5, 7}}, {'9', {7, 5, 7, 1, 7}}, {'+', {0, 2, 7, 2, 0}}, {'-', {0, 0, 7, 0, 0}},
    {'.', {0, 0, 0, 0, 2}}, {'%', {5, 1, 2, 4, 5}}, {'e', {0, 7, 7, 4, 7}}};
constexpr int kGlyphScale = 2, kGlyphAdvance = 4 * kGlyphScale;
constexpr int kNoteIndent = 6;  // notes' left (and right) margin

struct Canvas {  // display-referred RGB floats
  int w, h;
  std::vector<float> px;
  float* at(int x, int y) { return &px[(static_cast<std::size_t>(y) * w + x) * 3]; }
  void set(int x, int y, const std::array<float, 3>& c) {
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    std::copy(c.begin(), c.end(), at(x, y));
  }
};

// Draws `text` centred on x with its top at y.
void draw_bitmap_text(Canvas& canvas, int x_centre, int y_top, const std::string& text) {
  int x = x_centre - static_cast<int>(text.size()) * kGlyphAdvance / 2;
  for (char c : text) {
    for (const Glyph& g : kGlyphs) {
      if (g.c != c) continue;
      for (int row = 0; row < 5; ++row)
        for (int col = 0; col < 3; ++col)
          if (g.rows[row] & (4 >> col))
            for (int sy = 0; sy < kGlyphScale; ++sy)
              for (int sx = 0; sx < kGlyphScale; ++sx)
                canvas.set(x + col * kGlyphScale + sx, y_top + row * kGlyphScale + sy, {0.0f, 0.0f, 0.0f});
    }
    x += kGlyphAdvance;
  }
}

// The first of kFonts that loads, or nullptr.
const char* legend_font() {
  for (const char* font : kFonts)
    if (text_width("Ag", 12, font) >= 0) return font;
  return nullptr;
}

// Draws `text` centred on x with its baseline at y in a TrueType font; false if none loads.
bool draw_truetype_text(Canvas& canvas, int x_centre, int baseline, const std::string& text) {
  for (const char* font : kFonts)
    if (draw_text(canvas.px.data(), canvas.w, canvas.h, x_centre, baseline, text, 12, font, {0.0f, 0.0f, 0.0f},
                  TextAlign::kCentre))
      return true;
  return false;
}

std::string percent_label(double value) {
  if (value == 0.0) return "0";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%+.3g%%", 100.0 * value);
  return buffer;
}

}  // namespace

std::array<float, 3> diverging_colour(double t) {
  if (std::isnan(t)) return {0.5f, 0.5f, 0.5f};
  const float a = static_cast<float>(std::min(1.0, std::abs(t)));
  if (t > 0.0) return {1.0f, 1.0f - a, 1.0f - a};
  return {1.0f - a, 1.0f - a, 1.0f};
}

Image false_colour_map(const std::vector<float>& relative, int width, int height, double range) {
  Image image(width, height);
  for (std::size_t i = 0; i < relative.size() && i < image.rgb.size() / 3; ++i) {
    const std::array<float, 3> c = diverging_colour(relative[i] / range);
    for (int k = 0; k < 3; ++k) image.rgb[i * 3 + k] = static_cast<float>(srgb_decode(c[k]));
  }
  return image;
}

std::string difference_caption(double sigma) {
  if (!(sigma > 0.0)) return "";
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "sigma %g px: blue TEST<REF, red TEST>REF", sigma);
  return buffer;
}

std::vector<std::string> legend_note_lines(const std::vector<std::string>& notes, int canvas_width) {
  const char* font = legend_font();
  std::vector<std::string> lines;
  if (!font) return lines;
  for (const std::string& note : notes)
    for (std::string& line : wrap_text(note, canvas_width - 2 * kNoteIndent, 12, font)) lines.push_back(std::move(line));
  return lines;
}

Image false_colour_with_legend(const std::vector<float>& relative, int width, int height, double range,
                               const std::string& caption, const std::vector<std::string>& notes) {
  const int canvas_width = std::max(width, kMinLegendWidth);
  const std::vector<std::string> note_lines = legend_note_lines(notes, canvas_width);
  const int notes_height =
      note_lines.empty() ? 0 : static_cast<int>(note_lines.size()) * kLegendNoteLineHeight + kLegendNotesMargin;
  Canvas canvas{canvas_width, height + kLegendHeight + notes_height, {}};
  canvas.px.assign(static_cast<std::size_t>(canvas.w) * canvas.h * 3, 0.85f);  // light grey
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      canvas.set(x, y, diverging_colour(relative[static_cast<std::size_t>(y) * width + x] / range));
  for (int x = 0; x < canvas.w; ++x) canvas.set(x, height, {0.0f, 0.0f, 0.0f});  // separator

  // Colour bar from -range (left) to +range (right), with a frame and five ticks.
  const int x0 = 26, x1 = canvas.w - 27, bar_top = height + 20, bar_bottom = height + 32;
  for (int x = x0; x <= x1; ++x) {
    const double t = -1.0 + 2.0 * (x - x0) / static_cast<double>(x1 - x0);
    for (int y = bar_top; y <= bar_bottom; ++y) canvas.set(x, y, diverging_colour(t));
    canvas.set(x, bar_top - 1, {0.0f, 0.0f, 0.0f});
    canvas.set(x, bar_bottom + 1, {0.0f, 0.0f, 0.0f});
  }
  for (int y = bar_top - 1; y <= bar_bottom + 1; ++y) {
    canvas.set(x0 - 1, y, {0.0f, 0.0f, 0.0f});
    canvas.set(x1 + 1, y, {0.0f, 0.0f, 0.0f});
  }
  bool truetype = draw_truetype_text(canvas, canvas.w / 2, height + 15,
                                     caption.empty() ? "blue: TEST < REF    red: TEST > REF" : caption);
  for (int k = -2; k <= 2; ++k) {
    const int x = x0 + (x1 - x0) * (k + 2) / 4;
    for (int y = bar_bottom + 2; y <= bar_bottom + 4; ++y) canvas.set(x, y, {0.0f, 0.0f, 0.0f});
    const std::string label = percent_label(range * k / 2.0);
    if (!truetype || !draw_truetype_text(canvas, x, height + 49, label)) {
      truetype = false;
      draw_bitmap_text(canvas, x, height + 39, label);
    }
  }
  for (std::size_t i = 0; i < note_lines.size(); ++i)
    draw_text(canvas.px.data(), canvas.w, canvas.h, kNoteIndent,
              height + kLegendHeight + static_cast<int>(i + 1) * kLegendNoteLineHeight - 3, note_lines[i], 12,
              legend_font(), {0.0f, 0.0f, 0.0f});

  // Display values to linear, so write_png's sRGB encoding restores them.
  Image image(canvas.w, canvas.h);
  for (std::size_t i = 0; i < image.rgb.size(); ++i)
    image.rgb[i] = static_cast<float>(srgb_decode(std::clamp(canvas.px[i], 0.0f, 1.0f)));
  return image;
}

}  // namespace lamina
