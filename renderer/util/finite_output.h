// Every number a command writes is finite, or the command fails (docs/contracts.md, "Outputs"):
// the text writers (CSV columns, EXR header attributes) check their numbers here, before
// anything is written, so a failure leaves no file. JSON has its own walk over the document
// (renderer/cli/outputs.h, check_finite_numbers), with the same message.
#pragma once

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace lamina {

// "OUTPUT: FIELD is not finite (VALUE)": one line naming the output and the field.
struct NonFiniteOutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline std::string non_finite_message(const std::string& output, const std::string& field, const std::string& value) {
  return output + ": " + field + " is not finite (" + value + ")";
}

inline void check_finite_output(double v, const std::string& output, const std::string& field) {
  if (!std::isfinite(v)) throw NonFiniteOutputError(non_finite_message(output, field, std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf"));
}

// Whether `token` is a whole number in a spelling that is not finite, as printf, the streams,
// std::to_string or strtod write or read it: "nan", "-nan", "inf", "-inf", "infinity", "NaN",
// "nan(0x1)"... A word that merely starts so ("info", "infinite") is not.
inline bool is_non_finite_token(const std::string& token) {
  if (token.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  return end == token.c_str() + token.size() && !std::isfinite(v);
}

// The first non-finite number among the words of `text` (split at spaces, commas, semicolons,
// '=' and brackets: the separators of the lists and sentences a header value holds), or "".
inline std::string first_non_finite_word(const std::string& text) {
  std::string word;
  for (std::size_t i = 0; i <= text.size(); ++i) {
    const char c = i < text.size() ? text[i] : ' ';
    if (std::string(" \t\n,;=()[]").find(c) != std::string::npos) {  // "nan(0x1)" leaves the word nan
      if (is_non_finite_token(word)) return word;
      word.clear();
    } else {
      word += c;
    }
  }
  return "";
}

}  // namespace lamina
