// Labels that are never cut: text wrapped to a width (renderer/image/text.h's wrap_text), the
// contact sheet's label band grown to the longest wrapped label, and the notes under a
// false-colour legend. Needs the project's font (scripts/setup.sh: fonts-dejavu-core), as
// test_text.cpp does.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/image/contact_sheet.h"
#include "renderer/image/false_colour.h"
#include "renderer/image/text.h"

namespace lamina {
namespace {

const char* const kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

// The text with every space removed: what must survive wrapping (only spaces at breaks go).
std::string without_spaces(const std::string& s) {
  std::string t;
  for (char c : s)
    if (c != ' ') t += c;
  return t;
}

std::string joined_without_spaces(const std::vector<std::string>& lines) {
  std::string t;
  for (const std::string& l : lines) t += without_spaces(l);
  return t;
}

TEST(WrapText, EveryLineFitsAndNothingIsLost) {
  ASSERT_GT(text_width("Ag", 11, kFont), 0) << "DejaVu Sans must be installed (scripts/setup.sh)";
  const std::string text = "diff lambert-vs-layered +-25%, sigma 2 px head / base / default, random-walk, 16 spp";
  for (int width : {40, 60, 100, 160, 1000}) {
    SCOPED_TRACE(width);
    const std::vector<std::string> lines = wrap_text(text, width, 11, kFont);
    ASSERT_FALSE(lines.empty());
    for (const std::string& l : lines) {
      EXPECT_LE(text_width(l, 11, kFont), width) << l;
      EXPECT_FALSE(l.empty());
      EXPECT_NE(l.front(), ' ') << l;
      EXPECT_NE(l.back(), ' ') << l;
    }
    EXPECT_EQ(joined_without_spaces(lines), without_spaces(text));
  }
  EXPECT_EQ(wrap_text(text, 1000, 11, kFont), std::vector<std::string>{text});  // fits: unchanged
  EXPECT_TRUE(wrap_text("", 100, 11, kFont).empty());
  EXPECT_TRUE(wrap_text("   ", 100, 11, kFont).empty());
}

TEST(WrapText, BreaksBetweenLabelPartsFirstThenSpacesThenCharacters) {
  // "16 spp" is one part of "head / base / default, 16 spp": it moves to the next line whole
  // rather than leaving "16" behind, where a break at any space would.
  const std::string label = "head / base / default, 16 spp";
  const int width = text_width("head / base / default, 16", 11, kFont);
  const std::vector<std::string> lines = wrap_text(label, width, 11, kFont);
  EXPECT_EQ(lines, (std::vector<std::string>{"head / base / default,", "16 spp"}));
  // A part wider than the line goes by words, a word wider than the line by characters.
  const std::vector<std::string> words = wrap_text("REF lambert-vs-layered-and-more", text_width("REF lambert", 11, kFont), 11, kFont);
  ASSERT_GE(words.size(), 3u);
  EXPECT_EQ(words[0], "REF");
  EXPECT_EQ(joined_without_spaces(words), "REFlambert-vs-layered-and-more");
  // Even a line narrower than one character holds one character a line.
  EXPECT_EQ(wrap_text("abc", 1, 11, kFont), (std::vector<std::string>{"a", "b", "c"}));
  // A UTF-8 character (two bytes here) is never split.
  const std::vector<std::string> utf8 = wrap_text("\xc3\xa9\xc3\xa9\xc3\xa9", 1, 11, kFont);
  EXPECT_EQ(utf8, (std::vector<std::string>{"\xc3\xa9", "\xc3\xa9", "\xc3\xa9"}));
  // Without the font: one line, as it is.
  EXPECT_EQ(wrap_text("a b", 1, 11, "/no/such/font.ttf"), std::vector<std::string>{"a b"});
}

// True if any pixel of the column range [x0, x1) and row range [y0, y1) differs from `value`.
bool has_ink(const Image& image, int x0, int x1, int y0, int y1, float value) {
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < 3; ++c)
        if (image.pixel(x, y)[c] != value) return true;
  return false;
}

TEST(ContactSheet, LongLabelsWrapAndTheBandGrowsSoNothingIsCut) {
  const int thumb = 60;
  std::vector<ContactCell> cells(3, ContactCell{Image(30, 30), {"a", "b"}});
  cells[1].label = {"diff lambert-vs-layered", "REF head / base / default, random-walk, 16 spp", "TEST lambert"};
  const std::vector<std::string> lines = contact_label_lines(cells[1], thumb);
  ASSERT_GT(lines.size(), 3u);  // wrapped
  for (const std::string& l : lines) EXPECT_LE(text_width(l, kSheetFontSize, kFont), thumb) << l;
  EXPECT_EQ(joined_without_spaces(lines), without_spaces("diff lambert-vs-layered") +
                                              without_spaces("REF head / base / default, random-walk, 16 spp") + "TEST" +
                                              "lambert");
  const ContactSheetLayout l = contact_sheet_layout(cells, 3, thumb);
  EXPECT_EQ(l.label_lines, static_cast<int>(lines.size()));
  EXPECT_EQ(l.cell_height, thumb + l.label_lines * kSheetLineHeight);
  // Short labels keep the band of kSheetLabelLines lines.
  EXPECT_EQ(contact_sheet_layout({cells[0]}, 1, thumb).cell_height, thumb + kSheetLabelLines * kSheetLineHeight);
  EXPECT_EQ(contact_label_lines(ContactCell{Image(1, 1), {"", "b"}}, thumb), (std::vector<std::string>{"", "b"}));

  // Drawn: the last wrapped line has ink, and no text reaches the padding between the cells or
  // below the band (the background there is untouched), but for the anti-aliased edge of a
  // glyph whose ink starts a pixel left of the pen ('T'): one column next to the cell.
  bool labelled = false;
  const Image sheet = make_contact_sheet(cells, 3, thumb, &labelled);
  ASSERT_TRUE(labelled);
  const float background = sheet.pixel(0, 0)[0];
  const int x0 = kSheetPadding + (thumb + kSheetPadding), y0 = kSheetPadding;
  const int last_line_top = y0 + thumb + (l.label_lines - 1) * kSheetLineHeight;
  EXPECT_TRUE(has_ink(sheet, x0, x0 + thumb, last_line_top, last_line_top + kSheetLineHeight, background));
  EXPECT_FALSE(has_ink(sheet, x0 + thumb, x0 + thumb + kSheetPadding, y0, y0 + l.cell_height, background));
  EXPECT_FALSE(has_ink(sheet, x0 - kSheetPadding, x0 - 1, y0, y0 + l.cell_height, background));
  EXPECT_FALSE(has_ink(sheet, 0, sheet.width, y0 + l.cell_height, sheet.height, background));
}

TEST(FalseColour, NotesUnderTheLegendAreWrappedToTheCanvas) {
  const int w = 40, h = 20;
  std::vector<float> rel(static_cast<std::size_t>(w) * h);
  for (std::size_t i = 0; i < rel.size(); ++i) rel[i] = static_cast<float>(i % w) / w - 0.5f;
  const Image plain = false_colour_with_legend(rel, w, h, 0.5);
  const std::vector<std::string> notes = {"REF: head / base / default, random-walk, 16 spp",
                                          "TEST: head / base / a-variant-with-a-long-name / default, lambert, 16 spp"};
  const std::vector<std::string> lines = legend_note_lines(notes, kMinLegendWidth);
  ASSERT_GT(lines.size(), 2u);  // the second note wraps on the 280-pixel canvas
  for (const std::string& l : lines) EXPECT_LE(text_width(l, 12, kFont), kMinLegendWidth - 12) << l;
  EXPECT_EQ(joined_without_spaces(lines), without_spaces(notes[0]) + without_spaces(notes[1]));
  const Image noted = false_colour_with_legend(rel, w, h, 0.5, "", notes);
  ASSERT_EQ(noted.width, plain.width);
  ASSERT_EQ(noted.height, plain.height + static_cast<int>(lines.size()) * kLegendNoteLineHeight + kLegendNotesMargin);
  // The map and the legend above the notes are the same pixels; the notes have ink.
  EXPECT_TRUE(std::equal(plain.rgb.begin(), plain.rgb.end(), noted.rgb.begin()));
  const float grey = noted.pixel(noted.width - 1, noted.height - 1)[0];
  EXPECT_TRUE(has_ink(noted, 0, noted.width, plain.height, noted.height, grey));
  // The map alone is the legend's map.
  const Image map = false_colour_map(rel, w, h, 0.5);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(map.pixel(x, y)[c], plain.pixel(x, y)[c]) << x << "," << y;
}

TEST(FalseColour, CaptionNamesTheSmoothing) {
  EXPECT_EQ(difference_caption(0.0), "");
  EXPECT_EQ(difference_caption(2.0), "sigma 2 px: blue TEST<REF, red TEST>REF");
  EXPECT_EQ(difference_caption(0.5), "sigma 0.5 px: blue TEST<REF, red TEST>REF");
}

}  // namespace
}  // namespace lamina
