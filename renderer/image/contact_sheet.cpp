// Contact sheets (see contact_sheet.h).
#include "renderer/image/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

namespace lamina {
namespace {

namespace OIIO = OIIO_NAMESPACE;

const char* const kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";  // Debian fonts-dejavu-core
constexpr float kBackground = 0.02f;  // linear; about 0.15 once sRGB-encoded
constexpr float kTextColour[3] = {1.0f, 1.0f, 1.0f};

int thumbnail_height(const Image& image, int thumbnail_width) {
  if (image.width <= 0 || image.height <= 0) throw std::invalid_argument("contact sheet: an empty image");
  return std::max(1, static_cast<int>(std::lround(static_cast<double>(thumbnail_width) * image.height / image.width)));
}

// `text` shortened with ".." until it is at most `width` pixels wide in the sheet's font.
std::string fit_text(const std::string& text, int width) {
  std::string t = text;
  while (!t.empty()) {
    const std::string shown = t.size() == text.size() ? t : t + "..";
    const OIIO::ROI size = OIIO::ImageBufAlgo::text_size(shown, kSheetFontSize, kFont);
    if (!size.defined() || size.width() <= width) return shown;
    t.pop_back();
  }
  return t;
}

}  // namespace

ContactSheetLayout contact_sheet_layout(const std::vector<ContactCell>& cells, int columns, int thumbnail_width) {
  if (cells.empty()) throw std::invalid_argument("contact sheet: no images");
  if (columns < 1 || thumbnail_width < 1) throw std::invalid_argument("contact sheet: columns and thumbnail width must be positive");
  ContactSheetLayout l;
  l.columns = std::min<int>(columns, static_cast<int>(cells.size()));
  l.rows = (static_cast<int>(cells.size()) + l.columns - 1) / l.columns;
  int tallest = 0;
  for (const ContactCell& c : cells) tallest = std::max(tallest, thumbnail_height(c.image, thumbnail_width));
  l.cell_width = thumbnail_width;
  l.cell_height = tallest + kSheetLabelLines * kSheetLineHeight;
  l.width = kSheetPadding + l.columns * (l.cell_width + kSheetPadding);
  l.height = kSheetPadding + l.rows * (l.cell_height + kSheetPadding);
  return l;
}

Image make_contact_sheet(const std::vector<ContactCell>& cells, int columns, int thumbnail_width, bool* labelled) {
  const ContactSheetLayout l = contact_sheet_layout(cells, columns, thumbnail_width);
  Image sheet(l.width, l.height);
  std::fill(sheet.rgb.begin(), sheet.rgb.end(), kBackground);
  OIIO::ImageBuf canvas(OIIO::ImageSpec(l.width, l.height, 3, OIIO::TypeDesc::FLOAT), sheet.rgb.data());
  const bool have_font = OIIO::ImageBufAlgo::text_size("Ag", kSheetFontSize, kFont).defined();
  OIIO::geterror();  // a missing font leaves an error message pending
  if (labelled) *labelled = have_font;

  for (std::size_t i = 0; i < cells.size(); ++i) {
    const ContactCell& cell = cells[i];
    const int col = static_cast<int>(i) % l.columns, row = static_cast<int>(i) / l.columns;
    const int x0 = kSheetPadding + col * (l.cell_width + kSheetPadding);
    const int y0 = kSheetPadding + row * (l.cell_height + kSheetPadding);
    const int th = thumbnail_height(cell.image, thumbnail_width);

    // Resize in linear light (averaging radiance, as a camera with fewer pixels would), one
    // thread so the result never depends on scheduling.
    OIIO::ImageBuf src(OIIO::ImageSpec(cell.image.width, cell.image.height, 3, OIIO::TypeDesc::FLOAT),
                       const_cast<float*>(cell.image.rgb.data()));
    OIIO::ImageBuf thumb = OIIO::ImageBufAlgo::resize(src, "", 0.0f, OIIO::ROI(0, thumbnail_width, 0, th, 0, 1, 0, 3), 1);
    if (thumb.has_error()) throw std::runtime_error("contact sheet: resize failed: " + thumb.geterror());
    for (int y = 0; y < th; ++y)
      for (int x = 0; x < thumbnail_width; ++x) {
        float px[3];
        thumb.getpixel(x, y, px, 3);
        float* out = sheet.pixel(x0 + x, y0 + y);
        for (int c = 0; c < 3; ++c) out[c] = std::isfinite(px[c]) ? std::max(px[c], 0.0f) : 0.0f;
      }
    if (!have_font) continue;
    for (std::size_t line = 0; line < cell.label.size() && line < static_cast<std::size_t>(kSheetLabelLines); ++line) {
      const int baseline = y0 + th + static_cast<int>(line + 1) * kSheetLineHeight - 3;
      OIIO::ImageBufAlgo::render_text(canvas, x0, baseline, fit_text(cell.label[line], l.cell_width), kSheetFontSize, kFont,
                                      kTextColour);
    }
  }
  OIIO::geterror();
  return sheet;
}

}  // namespace lamina
