// The one parser of numbers written as text: every number that enters Lamina from the command
// line (renderer/cli/options.h), a CSV file (materials/fit) or a text field of a JSON file (a
// batch manifest's "r,g,b") goes through it, so that all of them accept the same spelling.
// JSON numbers themselves are read by the JSON parser, whose grammar (RFC 8259 section 6) is
// this decimal notation already; their ranges are checked by each reader.
//
// Why not strtod/strtoull: strtod also reads "nan", "inf", "infinity" and hexadecimal floats
// ("0x10" is 16), and overflows to infinity ("1e999") or underflows to 0 or a subnormal
// ("1e-320", whose reciprocal square is infinite) without a sign; strtoull with base 0 reads "010" as octal 8 and
// wraps "-1" to 2^64 - 1. Every parser here returns "" on success, else the reason, a phrase for
// "must be ... (got 'TEXT': REASON)" lines.
#pragma once

#include <cstdint>
#include <string>

namespace lamina {

// Decimal digits only (no sign, no space, no leading zero unless the value is 0), overflow
// checked: the whole range of std::uint64_t and nothing else.
std::string parse_u64(const std::string& text, std::uint64_t* out);

// An optional sign, then as parse_u64; fits a long long.
std::string parse_integer(const std::string& text, long long* out);

// Decimal notation only, [+-](digits[.digits] | .digits)[(e|E)[+-]digits], finite, and either 0
// or a normal double (magnitude at least 2.2250738585072014e-308): no "nan", "inf", hex,
// overflow ("1e999") or underflow ("1e-320", "1e-400").
std::string parse_real(const std::string& text, double* out);

// parse_real and lo <= value <= hi; the reason names the interval ("not in [1e-12, 1e+06]").
std::string parse_real_in(const std::string& text, double lo, double hi, double* out);

}  // namespace lamina
