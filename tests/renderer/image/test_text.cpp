// Text through FreeType (renderer/image/text.h) in the font the project installs
// (scripts/setup.sh: fonts-dejavu-core). A missing font fails here rather than silently leaving
// contact sheets unlabelled.
#include "renderer/image/text.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

namespace lamina {
namespace {

const char* const kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

// Bounding box of the pixels that differ from the background 0; returns the coverage sum.
double ink(const std::vector<float>& rgb, int w, int h, int* x0, int* x1, int* y0, int* y1) {
  double sum = 0.0;
  *x0 = w, *x1 = -1, *y0 = h, *y1 = -1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = rgb[(static_cast<std::size_t>(y) * w + x) * 3];
      if (v <= 0.0f) continue;
      sum += v;
      *x0 = std::min(*x0, x), *x1 = std::max(*x1, x), *y0 = std::min(*y0, y), *y1 = std::max(*y1, y);
    }
  return sum;
}

TEST(Text, WidthGrowsWithTheTextAndTheSize) {
  const int a = text_width("lamina", 12, kFont);
  ASSERT_GT(a, 0) << "DejaVu Sans must be installed (scripts/setup.sh)";
  EXPECT_GT(text_width("lamina lamina", 12, kFont), a);
  EXPECT_GT(text_width("lamina", 24, kFont), a);
  EXPECT_EQ(text_width("", 12, kFont), 0);
  EXPECT_EQ(text_width("x", 12, "/no/such/font.ttf"), -1);
}

TEST(Text, GlyphsSitOnTheBaselineAndAreCentredOrLeftAligned) {
  const int w = 200, h = 40, baseline = 30;
  std::vector<float> rgb(static_cast<std::size_t>(w) * h * 3, 0.0f);
  ASSERT_TRUE(draw_text(rgb.data(), w, h, 20, baseline, "Hxx", 16, kFont, {1.0f, 1.0f, 1.0f}));
  int x0, x1, y0, y1;
  ASSERT_GT(ink(rgb, w, h, &x0, &x1, &y0, &y1), 0.0);
  // 'H' and 'x' have no descender: the ink ends on the baseline row (the row above it) and
  // starts at the pen, give or take the glyphs' side bearing.
  EXPECT_LE(y1, baseline);
  EXPECT_GE(y1, baseline - 1);
  EXPECT_GE(y0, baseline - 16);  // no taller than the em
  EXPECT_NEAR(x0, 20, 3);
  EXPECT_NEAR(x1 - x0 + 1, text_width("Hxx", 16, kFont), 3);

  std::vector<float> centred(rgb.size(), 0.0f);
  ASSERT_TRUE(draw_text(centred.data(), w, h, 100, baseline, "Hxx", 16, kFont, {1.0f, 1.0f, 1.0f}, TextAlign::kCentre));
  int c0, c1, d0, d1;
  ink(centred, w, h, &c0, &c1, &d0, &d1);
  EXPECT_NEAR((c0 + c1) / 2.0, 100.0, 2.0);

  // Clipped at the image's edges, never written outside it.
  std::vector<float> tiny(4 * 4 * 3, 0.0f);
  EXPECT_TRUE(draw_text(tiny.data(), 4, 4, -5, 2, "WWW", 16, kFont, {1.0f, 1.0f, 1.0f}));
  EXPECT_FALSE(draw_text(tiny.data(), 4, 4, 0, 2, "x", 16, "/no/such/font.ttf", {1.0f, 1.0f, 1.0f}));
}

}  // namespace
}  // namespace lamina
