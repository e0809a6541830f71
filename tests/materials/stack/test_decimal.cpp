// The one parser of numbers written as text (materials/stack/decimal.h) and the one JSON parse
// (materials/stack/json_limits.h, parse_json_text): what each accepts, refuses, and says.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "materials/stack/decimal.h"
#include "materials/stack/json_limits.h"

namespace lamina {
namespace {

double real_or_nan(const std::string& text) {
  double v = std::nan("");
  return parse_real(text, &v).empty() ? v : std::nan("");
}

TEST(Decimal, AcceptsDecimalNotation) {
  EXPECT_EQ(real_or_nan("0"), 0.0);
  EXPECT_EQ(real_or_nan("-0.5"), -0.5);
  EXPECT_EQ(real_or_nan("+.5"), 0.5);
  EXPECT_EQ(real_or_nan("5."), 5.0);
  EXPECT_EQ(real_or_nan("1e3"), 1000.0);
  EXPECT_EQ(real_or_nan("2.5E-3"), 2.5e-3);
  EXPECT_EQ(real_or_nan("1.7976931348623157e308"), std::numeric_limits<double>::max());
  EXPECT_EQ(real_or_nan("2.2250738585072014e-308"), std::numeric_limits<double>::min());
  EXPECT_EQ(real_or_nan("0e-999"), 0.0);  // zero written small is zero, not an underflow
}

TEST(Decimal, RefusesWhatStrtodTakes) {
  double v = 7.0;
  for (const char* text : {"nan", "NaN", "inf", "-infinity", "0x10", "0x1p3", " 1", "1 ", "1,5", "", ".", "e5", "1e", "1e+",
                           "--1", "1e999", "-1e999", "1e-320", "-4.9e-324", "1e-400"}) {
    const std::string why = parse_real(text, &v);
    EXPECT_FALSE(why.empty()) << "'" << text << "' was accepted";
  }
  EXPECT_EQ(v, 7.0);  // untouched on failure
  EXPECT_NE(parse_real("1e999", &v).find("too large"), std::string::npos);
  EXPECT_NE(parse_real("1e-320", &v).find("too small"), std::string::npos);
}

TEST(Decimal, RangeNamesTheInterval) {
  double v = 0.0;
  EXPECT_EQ(parse_real_in("0.5", 0.0, 1.0, &v), "");
  EXPECT_EQ(v, 0.5);
  EXPECT_EQ(parse_real_in("1e300", -1e6, 1e6, &v), "not in [-1e+06, 1e+06]");
  EXPECT_EQ(parse_real_in("nan", 0.0, 1.0, &v), "not a finite decimal number");
}

TEST(Decimal, Integers) {
  std::uint64_t u = 0;
  EXPECT_EQ(parse_u64("18446744073709551615", &u), "");
  EXPECT_EQ(u, std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(parse_u64("18446744073709551616", &u), "above 18446744073709551615");
  EXPECT_EQ(parse_u64("010", &u), "a leading zero");
  EXPECT_EQ(parse_u64("-1", &u), "a sign");
  long long i = 0;
  EXPECT_EQ(parse_integer("-9223372036854775808", &i), "");
  EXPECT_EQ(i, std::numeric_limits<long long>::min());
  EXPECT_EQ(parse_integer("0x10", &i), "not decimal digits");
}

// The JSON library's exceptions become a reason with the JSON path where it stopped.
TEST(JsonText, NumberTooLargeNamesItsPath) {
  nlohmann::json j;
  std::string path;
  EXPECT_EQ(parse_json_text(R"({"settings": {"seed": 1, "width": 1e999}})", &j, &path),
            "number '1e999' is too large for a double (at most 1.79769e+308)");
  EXPECT_EQ(path, "settings.width");
  EXPECT_EQ(parse_json_text(R"({"layers": [{"g": 0}, {"sigma_a": [1, 2, -1e400]}]})", &j, &path).find("number '-1e400'"), 0u);
  EXPECT_EQ(path, "layers[1].sigma_a[2]");
  // Without `path`, the reason starts with it.
  EXPECT_EQ(parse_json_text(R"([1, [2, 1e999]])", &j), "[1][1]: number '1e999' is too large for a double (at most 1.79769e+308)");
}

TEST(JsonText, MalformedNamesLineAndColumnWithoutTheLibrarysTag) {
  nlohmann::json j;
  const std::string why = parse_json_text("{\n  \"a\": 1,,\n}", &j);
  EXPECT_EQ(why.find("malformed JSON: parse error at line 2, column"), 0u) << why;
  EXPECT_EQ(why.find("[json.exception"), std::string::npos) << why;
  EXPECT_NE(parse_json_text(std::string(600, '[') + std::string(600, ']'), &j).find("nested deeper than"), std::string::npos);
  EXPECT_EQ(parse_json_text(R"({"a": [1, {"b": null}], "c": "1e999"})", &j), "");
  EXPECT_EQ(j["c"], "1e999");
}

// A valid document is parsed once, without the path tracker; a failing one again, with it: the
// path still names the element in a long array, and the value parsed is the library's own.
TEST(JsonText, LongArraysKeepTheirPathsAndValues) {
  std::string text = "[";
  for (int i = 0; i < 5000; ++i) text += "{\"x\": " + std::to_string(i) + "}, ";
  nlohmann::json j;
  std::string path;
  EXPECT_EQ(parse_json_text(text + "{\"x\": 1e999}]", &j, &path).find("number '1e999'"), 0u);
  EXPECT_EQ(path, "[5000].x");
  EXPECT_EQ(parse_json_text(text + "{}]", &j), "");
  EXPECT_EQ(j, nlohmann::json::parse(text + "{}]"));
}

}  // namespace
}  // namespace lamina
