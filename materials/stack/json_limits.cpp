// Nesting depth of JSON text, before parsing (see json_limits.h).
#include "materials/stack/json_limits.h"

namespace lamina {

std::optional<std::size_t> json_nesting_exceeds(std::string_view text, int max_depth) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;  // the escaped character (", \, /, b, f, n, r, t or u) cannot end the string
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) return i;
    } else if (c == ']' || c == '}') {
      // An unbalanced close is the parser's error to report; never let it make room for more.
      if (depth > 0) --depth;
    }
  }
  return std::nullopt;
}

std::string json_nesting_message(std::size_t offset, int max_depth) {
  return "JSON nested deeper than " + std::to_string(max_depth) + " levels (at byte " + std::to_string(offset) + ")";
}

}  // namespace lamina
