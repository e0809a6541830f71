#include "materials/stack/decimal.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace lamina {

std::string parse_u64(const std::string& text, std::uint64_t* out) {
  if (text.empty()) return "empty";
  if (text[0] == '-' || text[0] == '+') return "a sign";
  std::uint64_t v = 0;
  for (char ch : text) {
    if (ch < '0' || ch > '9') return "not decimal digits";
    const std::uint64_t d = static_cast<std::uint64_t>(ch - '0');
    if (v > (std::numeric_limits<std::uint64_t>::max() - d) / 10) return "above 18446744073709551615";
    v = v * 10 + d;
  }
  if (text.size() > 1 && text[0] == '0') return "a leading zero";
  *out = v;
  return "";
}

std::string parse_integer(const std::string& text, long long* out) {
  const bool negative = !text.empty() && text[0] == '-';
  const std::size_t start = !text.empty() && (text[0] == '-' || text[0] == '+') ? 1 : 0;
  std::uint64_t magnitude = 0;
  const std::string why = parse_u64(text.substr(start), &magnitude);
  if (why == "empty" || why == "a sign") return "not decimal digits";
  if (why.rfind("above", 0) == 0) return "too large";
  if (!why.empty()) return why;
  const std::uint64_t limit = static_cast<std::uint64_t>(std::numeric_limits<long long>::max()) + (negative ? 1 : 0);
  if (magnitude > limit) return "too large";
  *out = negative ? static_cast<long long>(0 - magnitude) : static_cast<long long>(magnitude);
  return "";
}

std::string parse_real(const std::string& text, double* out) {
  std::size_t i = 0, n = text.size();
  bool nonzero = false;
  auto digits = [&](bool mantissa) {
    const std::size_t from = i;
    for (; i < n && text[i] >= '0' && text[i] <= '9'; ++i) nonzero = nonzero || (mantissa && text[i] != '0');
    return i - from;
  };
  if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
  std::size_t mantissa = digits(true);
  if (i < n && text[i] == '.') {
    ++i;
    mantissa += digits(true);
  }
  bool ok = mantissa > 0;
  if (ok && i < n && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
    ok = digits(false) > 0;
  }
  if (!ok || i != n) return "not a finite decimal number";
  errno = 0;
  const double v = std::strtod(text.c_str(), nullptr);
  if (!std::isfinite(v)) return "not finite (too large)";
  if (nonzero && !(std::abs(v) >= std::numeric_limits<double>::min()))
    return "too small (a non-zero magnitude below 2.2250738585072014e-308)";
  *out = v;
  return "";
}

std::string parse_real_in(const std::string& text, double lo, double hi, double* out) {
  double v = 0.0;
  const std::string why = parse_real(text, &v);
  if (!why.empty()) return why;
  if (!(v >= lo && v <= hi)) {
    char interval[96];
    std::snprintf(interval, sizeof interval, "not in [%g, %g]", lo, hi);
    return interval;
  }
  *out = v;
  return "";
}

}  // namespace lamina
