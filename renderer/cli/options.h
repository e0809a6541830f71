// The one validation layer of the command line (docs/contracts.md, "Command line: common
// rules"): every numeric option of every subcommand goes through a validator made here, so a
// bad value is refused the same way everywhere, by the argument parser, before anything is read
// or computed, with one line naming the option: `lamina <command>: --spp: must be ...`.
//
// Why not CLI11's own conversion and validators: CLI11 (2.1) converts integers with
// strtoull/strtoll in base 0, so "-1" for a std::uint64_t wraps to 2^64 - 1, a 30-digit seed
// saturates to 2^64 - 1, "0x10" is 16 and "010" is 8 (octal); its PositiveNumber and
// NonNegativeNumber accept "nan" (every comparison with NaN is false), and floating options take
// "inf", "nan" and hex floats. The validators below run on the option's text before CLI11
// converts it, and accept only text that CLI11 then converts to the value we checked:
//   - integers: optional sign, decimal digits, no leading zero (CLI11 would read "010" as
//     octal), no overflow; seeds: digits only, no sign, at most 2^64 - 1;
//   - reals: decimal notation only ([+-]digits[.digits][e[+-]digits]), finite: no "nan", no
//     "inf", no hex, no overflow to infinity ("1e999"), no underflow to a subnormal or 0.
// Header only: the lamina executable is the only user (renderer/cli/*.cpp).
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "materials/stack/decimal.h"
#include "renderer/scene/scene_gltf.h"

namespace lamina::cli {

// ---------------------------------------------------------------------------------------------
// The strict parsers, shared with the CSV and manifest readers (materials/stack/decimal.h). Each
// returns "" on success, else the reason (a phrase for "must be ..." lines).
using lamina::parse_integer;
using lamina::parse_real;
using lamina::parse_u64;

// ---------------------------------------------------------------------------------------------
// CLI11 validators built on the parsers. CLI11 prefixes the option's name: "--spp: must be ...".

inline std::string in_quotes(const std::string& text) { return "'" + text + "'"; }

// A bound as written in messages and help: integers in full ("90", "1000000"), others in the
// shortest %g form that reads back as `v`.
inline std::string number_text(double v) {
  char buf[40];
  if (v == std::floor(v) && std::abs(v) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return buf;
  }
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

// An unsigned 64-bit seed, 0 to 2^64 - 1, written in decimal digits.
inline CLI::Validator seed() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::uint64_t v = 0;
        const std::string why = parse_u64(text, &v);
        if (why.empty()) return "";
        return "must be an integer from 0 to 18446744073709551615 in decimal digits (got " + in_quotes(text) + ": " + why +
               ")";
      },
      "in [0, 2^64-1]", "seed");
}

// A decimal integer in [lo, hi]. `part` names an element of a list option ("w" of --crop
// x,y,w,h): "--crop: w must be ...".
inline CLI::Validator integer(long long lo, long long hi, const std::string& part = "") {
  const std::string what = (part.empty() ? "" : part + " ") + "must be an integer between " + std::to_string(lo) + " and " +
                           std::to_string(hi);
  return CLI::Validator(
      [lo, hi, what](std::string& text) -> std::string {
        long long v = 0;
        const std::string why = parse_integer(text, &v);
        if (!why.empty()) return what + " (got " + in_quotes(text) + ": " + why + ")";
        if (v < lo || v > hi) return what + " (got " + text + ")";
        return "";
      },
      "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", "integer");
}

// A finite decimal number in an interval whose ends may be open (then excluded); an infinite end
// means no bound on that side.
inline CLI::Validator real(double lo, double hi, bool lo_open = false, bool hi_open = false) {
  std::string interval;
  if (std::isinf(lo) && std::isinf(hi)) {
    interval = "";
  } else if (std::isinf(hi)) {
    interval = std::string(lo_open ? "> " : ">= ") + number_text(lo);
  } else if (std::isinf(lo)) {
    interval = std::string(hi_open ? "< " : "<= ") + number_text(hi);
  } else {
    interval = std::string("in ") + (lo_open ? "(" : "[") + number_text(lo) + ", " + number_text(hi) + (hi_open ? ")" : "]");
  }
  const std::string what = interval.empty() ? "a finite number" : "a finite number " + interval;
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0.0;
        const std::string why = parse_real(text, &v);
        if (!why.empty()) return "must be " + what + " (got " + in_quotes(text) + ": " + why + ")";
        const bool below = lo_open ? !(v > lo) : !(v >= lo);
        const bool above = hi_open ? !(v < hi) : !(v <= hi);
        if (below || above) return "must be " + what + " (got " + text + ")";
        return "";
      },
      interval.empty() ? "finite" : interval, "real");
}

inline CLI::Validator finite() {
  const double inf = std::numeric_limits<double>::infinity();
  return real(-inf, inf);
}
inline CLI::Validator positive() { return real(0.0, std::numeric_limits<double>::infinity(), true); }
inline CLI::Validator non_negative() { return real(0.0, std::numeric_limits<double>::infinity()); }

// `lamina render --env`: a number or R,G,B is a radiance, finite and >= 0; anything else is a
// file name, left to the renderer (which reads it). The value is numeric exactly when
// EnvironmentMap::from_argument (renderer/render/environment.cpp) reads it as numbers: every
// comma-separated part is something strtod reads whole.
inline CLI::Validator environment() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (text.empty()) return "must be a number, R,G,B or an EXR/HDR file (got '')";
        std::vector<std::string> parts;
        std::size_t start = 0;
        for (std::size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1)
          parts.push_back(text.substr(start, comma - start));
        parts.push_back(text.substr(start));
        std::size_t numeric = 0;
        for (const std::string& p : parts) {
          const char* begin = p.c_str();
          char* end = nullptr;
          std::strtod(begin, &end);
          if (end == begin) continue;
          while (*end == ' ' || *end == '\t') ++end;
          if (*end == '\0') ++numeric;
        }
        if (numeric != parts.size()) return "";  // a file name: the renderer reads (or refuses) it
        if (parts.size() != 1 && parts.size() != 3)
          return "must be a number, R,G,B or an EXR/HDR file (got " + in_quotes(text) + ": " + std::to_string(parts.size()) +
                 " numbers)";
        for (const std::string& p : parts) {
          double v = 0.0;
          const std::string why = parse_real(p, &v);
          if (!why.empty() || v < 0.0)
            return "radiance must be finite and >= 0, in decimal (got " + in_quotes(text) + ")";
          if (v > kMaxLightStrength)  // finite doubles beyond it overflow the float image
            return "radiance " + in_quotes(text) + " is above the largest light strength, " + light_strength_limit();
        }
        return "";
      },
      "NUMBER|R,G,B|FILE", "environment");
}

// ---------------------------------------------------------------------------------------------
// Errors from a command line that CLI11 cannot see (combinations of options, output paths): the
// subcommand prints them as one line, `lamina <command>: message`.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A message on one line: each run of line breaks (OpenImageIO's messages may hold them) becomes
// "; ", and trailing ones are dropped.
inline std::string one_line(const std::string& message) {
  std::string s;
  bool pending_break = false;
  for (char ch : message) {
    if (ch == '\n' || ch == '\r') {
      pending_break = !s.empty();
      continue;
    }
    if (pending_break) s += "; ";
    pending_break = false;
    s += ch;
  }
  return s;
}

// CLI11's message for a parse error, first line only (CLI11 may append its help hint).
inline std::string parse_error_line(const CLI::ParseError& e) {
  std::string m = e.what();
  if (const auto nl = m.find('\n'); nl != std::string::npos) m.resize(nl);
  return m;
}

}  // namespace lamina::cli
