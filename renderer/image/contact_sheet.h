// Contact sheets: a grid of labelled thumbnails in one picture, for looking over a batch.
#pragma once

#include <string>
#include <vector>

#include "renderer/image/image.h"

namespace lamina {

struct ContactCell {
  Image image;                     // linear RGB, any size (resized to the thumbnail width)
  std::vector<std::string> label;  // lines drawn under the thumbnail, each wrapped to the cell
};

// The layout: thumbnails `thumbnail_width` wide with the aspect ratio of their image, in cells
// as tall as the tallest thumbnail plus the label band; `columns` cells a row (fewer if there
// are fewer cells), kSheetPadding between cells and around the edge. The label band holds the
// most label lines of any cell once wrapped to the cell width (text.h's wrap_text), at least
// kSheetLabelLines, so no label is cut.
constexpr int kSheetPadding = 8;
constexpr int kSheetLabelLines = 2;
constexpr int kSheetLineHeight = 14;
constexpr int kSheetFontSize = 11;
struct ContactSheetLayout {
  int columns = 0, rows = 0;
  int cell_width = 0, cell_height = 0;  // thumbnail area + label band
  int label_lines = 0;                  // lines in the label band
  int width = 0, height = 0;
};
// Throws std::invalid_argument for no cells or non-positive sizes.
ContactSheetLayout contact_sheet_layout(const std::vector<ContactCell>& cells, int columns, int thumbnail_width);

// A cell's label as drawn: each line wrapped to `width` pixels in the sheet's font (one line per
// label line without the font).
std::vector<std::string> contact_label_lines(const ContactCell& cell, int width);

// The sheet in linear RGB (ready for write_png): dark grey background, thumbnails (resized in
// linear light by area averaging), labels in DejaVu Sans through FreeType (text.h), wrapped to
// the cell width. Without that font the labels are left out (`labelled` says which happened).
// Deterministic: the same cells give the same pixels.
Image make_contact_sheet(const std::vector<ContactCell>& cells, int columns, int thumbnail_width, bool* labelled = nullptr);

}  // namespace lamina
