// Text through FreeType (see text.h).
#include "renderer/image/text.h"

#include <ft2build.h>
#include FT_FREETYPE_H

#include <algorithm>
#include <map>
#include <mutex>

namespace lamina {
namespace {

// One FreeType library and one face per font file, for the process; FreeType objects are not
// thread-safe, so every use holds the mutex (text is drawn once per picture, never per sample).
struct Fonts {
  std::mutex mutex;
  FT_Library library = nullptr;
  bool library_failed = false;
  std::map<std::string, FT_Face> faces;  // nullptr: the file could not be loaded

  FT_Face face(const std::string& path, int pixel_size) {
    if (!library && !library_failed) library_failed = FT_Init_FreeType(&library) != 0;
    if (library_failed) return nullptr;
    auto it = faces.find(path);
    if (it == faces.end()) {
      FT_Face f = nullptr;
      if (FT_New_Face(library, path.c_str(), 0, &f) != 0) f = nullptr;
      it = faces.emplace(path, f).first;
    }
    if (it->second && FT_Set_Pixel_Sizes(it->second, 0, static_cast<FT_UInt>(pixel_size)) != 0) return nullptr;
    return it->second;
  }
};

Fonts& fonts() {
  static Fonts f;
  return f;
}

// Sets `text` from pen position `pen` (26.6 fixed point) with kerning: calls each(slot, pen)
// for every glyph loaded with `flags`, at the pen where it starts. Returns the pen after it.
template <typename Each>
long set_glyphs(FT_Face face, const std::string& text, FT_Int32 flags, long pen, Each each) {
  FT_UInt previous = 0;
  for (unsigned char c : text) {
    const FT_UInt glyph = FT_Get_Char_Index(face, c);
    if (previous && glyph && FT_HAS_KERNING(face)) {
      FT_Vector kern;
      if (FT_Get_Kerning(face, previous, glyph, FT_KERNING_DEFAULT, &kern) == 0) pen += kern.x;
    }
    previous = glyph;
    if (FT_Load_Glyph(face, glyph, flags) != 0) continue;
    each(face->glyph, pen);
    pen += face->glyph->advance.x;
  }
  return pen;
}

// The pen advance of `text` in whole pixels.
int advance_width(FT_Face face, const std::string& text) {
  return static_cast<int>((set_glyphs(face, text, FT_LOAD_DEFAULT, 0, [](FT_GlyphSlot, long) {}) + 32) >> 6);
}

}  // namespace

int text_width(const std::string& text, int pixel_size, const std::string& font_path) {
  Fonts& f = fonts();
  const std::lock_guard<std::mutex> lock(f.mutex);
  FT_Face face = f.face(font_path, pixel_size);
  return face ? advance_width(face, text) : -1;
}

bool draw_text(float* rgb, int width, int height, int x, int baseline, const std::string& text, int pixel_size,
               const std::string& font_path, const std::array<float, 3>& colour, TextAlign align) {
  Fonts& f = fonts();
  const std::lock_guard<std::mutex> lock(f.mutex);
  FT_Face face = f.face(font_path, pixel_size);
  if (!face) return false;
  const long start = static_cast<long>(align == TextAlign::kCentre ? x - advance_width(face, text) / 2 : x) << 6;
  set_glyphs(face, text, FT_LOAD_RENDER, start, [&](FT_GlyphSlot slot, long pen) {
    const FT_Bitmap& bitmap = slot->bitmap;
    const int left = static_cast<int>((pen + 32) >> 6) + slot->bitmap_left;
    const int top = baseline - slot->bitmap_top;
    for (unsigned row = 0; row < bitmap.rows; ++row) {
      const int y = top + static_cast<int>(row);
      if (y < 0 || y >= height) continue;
      for (unsigned col = 0; col < bitmap.width; ++col) {
        const int px = left + static_cast<int>(col);
        if (px < 0 || px >= width) continue;
        const float a = bitmap.buffer[row * static_cast<unsigned>(std::abs(bitmap.pitch)) + col] / 255.0f;
        float* p = rgb + (static_cast<std::size_t>(y) * width + px) * 3;
        for (int k = 0; k < 3; ++k) p[k] = p[k] * (1.0f - a) + colour[k] * a;
      }
    }
  });
  return true;
}

namespace {

// The longest prefix of `word` (at least one character) that fits in `max_width`, ending on a
// UTF-8 character boundary.
std::size_t fitting_prefix(FT_Face face, const std::string& word, int max_width) {
  std::size_t best = 0;
  for (std::size_t n = 1; n <= word.size(); ++n) {
    if (n < word.size() && (static_cast<unsigned char>(word[n]) & 0xC0) == 0x80) continue;  // inside a character
    if (best > 0 && advance_width(face, word.substr(0, n)) > max_width) break;
    best = n;
  }
  return best;
}

}  // namespace

namespace {

// `text` cut at its spaces: at every space (`any`), or only at those after a ',' or '/' (the
// breaks between the parts of a label, "head / base / default, 16 spp"). Runs of spaces at a
// cut are dropped.
std::vector<std::string> pieces_of(const std::string& text, bool any) {
  std::vector<std::string> pieces;
  std::string piece;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const bool cut = text[i] == ' ' && (any || piece.empty() || piece.back() == ',' || piece.back() == '/');
    if (!cut) {
      piece += text[i];
    } else if (!piece.empty()) {
      pieces.push_back(piece);
      piece.clear();
    }
  }
  if (!piece.empty()) pieces.push_back(piece);
  return pieces;
}

// Appends `text` to the lines, `line` being the one being filled: level 0 places whole parts of a
// label, a part wider than a line goes by words (level 1), a word wider than a line by
// characters (level 2).
void wrap_into(FT_Face face, const std::string& text, int max_width, int level, std::vector<std::string>& lines,
               std::string& line) {
  if (level == 2) {  // `line` is empty here
    std::string word = text;
    while (advance_width(face, word) > max_width) {
      const std::size_t n = fitting_prefix(face, word, max_width);
      lines.push_back(word.substr(0, n));
      word.erase(0, n);
    }
    line = word;
    return;
  }
  for (const std::string& piece : pieces_of(text, level == 1)) {
    const std::string joined = line.empty() ? piece : line + " " + piece;
    if (advance_width(face, joined) <= max_width) {
      line = joined;
      continue;
    }
    if (!line.empty()) lines.push_back(line);
    line.clear();
    if (advance_width(face, piece) <= max_width)
      line = piece;
    else
      wrap_into(face, piece, max_width, level + 1, lines, line);
  }
}

}  // namespace

std::vector<std::string> wrap_text(const std::string& text, int max_width, int pixel_size, const std::string& font_path) {
  Fonts& f = fonts();
  const std::lock_guard<std::mutex> lock(f.mutex);
  FT_Face face = f.face(font_path, pixel_size);
  if (!face) return text.empty() ? std::vector<std::string>{} : std::vector<std::string>{text};
  std::vector<std::string> lines;
  std::string line;
  wrap_into(face, text, max_width, 0, lines, line);
  if (!line.empty()) lines.push_back(line);
  return lines;
}

}  // namespace lamina
