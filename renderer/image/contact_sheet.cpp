// Contact sheets (see contact_sheet.h).
#include "renderer/image/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <vector>

#include "renderer/image/text.h"

namespace lamina {
namespace {

const char* const kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";  // Debian fonts-dejavu-core
constexpr float kBackground = 0.02f;  // linear; about 0.15 once sRGB-encoded
constexpr std::array<float, 3> kTextColour = {1.0f, 1.0f, 1.0f};

int thumbnail_height(const Image& image, int thumbnail_width) {
  if (image.width <= 0 || image.height <= 0) throw std::invalid_argument("contact sheet: an empty image");
  return std::max(1, static_cast<int>(std::lround(static_cast<double>(thumbnail_width) * image.height / image.width)));
}

// Per destination pixel along one axis, the source pixels its footprint [i s, (i + 1) s)
// overlaps (s = source / destination size) and their shares of it.
struct AxisWeights {
  std::vector<int> first, count;
  std::vector<double> weight;  // count[i] entries from offset[i]
  std::vector<std::size_t> offset;
};

AxisWeights area_weights(int source, int destination) {
  AxisWeights a;
  const double scale = static_cast<double>(source) / destination;
  for (int i = 0; i < destination; ++i) {
    const double lo = i * scale, hi = (i + 1) * scale;
    const int j0 = static_cast<int>(std::floor(lo));
    const int j1 = std::min(source - 1, static_cast<int>(std::ceil(hi)) - 1);
    a.first.push_back(j0);
    a.offset.push_back(a.weight.size());
    for (int j = j0; j <= j1; ++j)
      a.weight.push_back((std::min(hi, j + 1.0) - std::max(lo, static_cast<double>(j))) / scale);
    a.count.push_back(j1 - j0 + 1);
  }
  return a;
}

// The image resampled to width x height by area averaging (each thumbnail pixel the mean
// radiance of the source area it covers, as a camera with fewer pixels would record).
Image resize_by_area(const Image& source, int width, int height) {
  const AxisWeights ax = area_weights(source.width, width), ay = area_weights(source.height, height);
  Image out(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      double sum[3] = {0.0, 0.0, 0.0};
      for (int v = 0; v < ay.count[y]; ++v) {
        const double wy = ay.weight[ay.offset[y] + v];
        for (int u = 0; u < ax.count[x]; ++u) {
          const double w = wy * ax.weight[ax.offset[x] + u];
          const float* p = source.pixel(ax.first[x] + u, ay.first[y] + v);
          for (int c = 0; c < 3; ++c) sum[c] += w * (std::isfinite(p[c]) ? std::max(p[c], 0.0f) : 0.0f);
        }
      }
      float* o = out.pixel(x, y);
      for (int c = 0; c < 3; ++c) o[c] = static_cast<float>(sum[c]);
    }
  return out;
}

}  // namespace

std::vector<std::string> contact_label_lines(const ContactCell& cell, int width) {
  std::vector<std::string> lines;
  for (const std::string& text : cell.label) {
    std::vector<std::string> wrapped = wrap_text(text, width, kSheetFontSize, kFont);
    if (wrapped.empty()) wrapped.push_back("");  // an empty line keeps its place
    for (std::string& line : wrapped) lines.push_back(std::move(line));
  }
  return lines;
}

ContactSheetLayout contact_sheet_layout(const std::vector<ContactCell>& cells, int columns, int thumbnail_width) {
  if (cells.empty()) throw std::invalid_argument("contact sheet: no images");
  if (columns < 1 || thumbnail_width < 1) throw std::invalid_argument("contact sheet: columns and thumbnail width must be positive");
  ContactSheetLayout l;
  l.columns = std::min<int>(columns, static_cast<int>(cells.size()));
  l.rows = (static_cast<int>(cells.size()) + l.columns - 1) / l.columns;
  int tallest = 0;
  l.label_lines = kSheetLabelLines;
  for (const ContactCell& c : cells) {
    tallest = std::max(tallest, thumbnail_height(c.image, thumbnail_width));
    l.label_lines = std::max(l.label_lines, static_cast<int>(contact_label_lines(c, thumbnail_width).size()));
  }
  l.cell_width = thumbnail_width;
  l.cell_height = tallest + l.label_lines * kSheetLineHeight;
  l.width = kSheetPadding + l.columns * (l.cell_width + kSheetPadding);
  l.height = kSheetPadding + l.rows * (l.cell_height + kSheetPadding);
  return l;
}

Image make_contact_sheet(const std::vector<ContactCell>& cells, int columns, int thumbnail_width, bool* labelled) {
  const ContactSheetLayout l = contact_sheet_layout(cells, columns, thumbnail_width);
  Image sheet(l.width, l.height);
  std::fill(sheet.rgb.begin(), sheet.rgb.end(), kBackground);
  const bool have_font = text_width("Ag", kSheetFontSize, kFont) >= 0;
  if (labelled) *labelled = have_font;

  for (std::size_t i = 0; i < cells.size(); ++i) {
    const ContactCell& cell = cells[i];
    const int col = static_cast<int>(i) % l.columns, row = static_cast<int>(i) / l.columns;
    const int x0 = kSheetPadding + col * (l.cell_width + kSheetPadding);
    const int y0 = kSheetPadding + row * (l.cell_height + kSheetPadding);
    const int th = thumbnail_height(cell.image, thumbnail_width);

    // Resized in linear light (non-finite and negative values as black).
    const Image thumb = resize_by_area(cell.image, thumbnail_width, th);
    for (int y = 0; y < th; ++y)
      for (int x = 0; x < thumbnail_width; ++x) std::copy_n(thumb.pixel(x, y), 3, sheet.pixel(x0 + x, y0 + y));
    if (!have_font) continue;
    const std::vector<std::string> lines = contact_label_lines(cell, l.cell_width);
    for (std::size_t line = 0; line < lines.size(); ++line) {
      const int baseline = y0 + th + static_cast<int>(line + 1) * kSheetLineHeight - 3;
      draw_text(sheet.rgb.data(), l.width, l.height, x0, baseline, lines[line], kSheetFontSize, kFont, kTextColour);
    }
  }
  return sheet;
}

}  // namespace lamina
