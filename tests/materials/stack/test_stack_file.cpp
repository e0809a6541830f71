// The material file reader: the contract's example round-trips, composites mix by volume
// fraction, and every kind of bad input is rejected with "SOURCE: JSON.PATH: reason".
#include "materials/stack/stack_file.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "materials/phase/henyey_greenstein.h"

namespace lamina {
namespace {

// A valid two-layer file; the error tests below each break one thing in it.
const char* kGood = R"({
  "lamina_material": 1,
  "name": "skin",
  "above_ior": 1.0,
  "layers": [
    { "name": "epidermis", "ior": 1.4, "thickness": 0.1,
      "sigma_a": [0.4, 0.1, 0.9], "sigma_s": 30.0, "g": 0.2 },
    { "name": "dermis", "ior": 1.4, "thickness": 1.0,
      "components": [
        { "fraction": 0.6, "sigma_a": [1.0, 2.0, 3.0], "sigma_s": 40.0, "g": 0.0 },
        { "fraction": 0.4, "sigma_a": 0.5, "sigma_s": [10.0, 20.0, 30.0], "g": [0.9, 0.8, 0.7] } ] }
  ],
  "below": { "lambert": [0.5, 0.4, 0.3] }
})";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not in the template";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Parses `text` expecting a StackFileError whose message starts with "skin.json: PATH: " and
// contains `reason`.
void expect_error(const std::string& text, const std::string& path, const std::string& reason) {
  try {
    parse_stack_json(text, "skin.json");
    ADD_FAILURE() << "accepted; expected an error at " << path;
  } catch (const StackFileError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("skin.json: " + path + ": ", 0), 0u) << msg;
    EXPECT_NE(msg.find(reason), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
  }
}

TEST(StackFile, GoodTemplateParses) {
  const LayerStack s = parse_stack_json(kGood, "skin.json");
  EXPECT_EQ(s.name, "skin");
  ASSERT_EQ(s.layers.size(), 2u);
  EXPECT_EQ(s.below.kind, Below::Kind::Lambert);
  EXPECT_EQ(s.below.albedo, Spectrum(0.5, 0.4, 0.3));
  EXPECT_TRUE(validate_stack(s).empty());
}

TEST(StackFile, CompositeMixesByVolumeFraction) {
  const LayerStack s = parse_stack_json(kGood, "skin.json");
  const Layer& d = s.layers[1];
  ASSERT_EQ(d.lobes.size(), 2u);
  // sigma_a = sum w_i sigma_a_i
  EXPECT_DOUBLE_EQ(d.sigma_a[0], 0.6 * 1.0 + 0.4 * 0.5);
  EXPECT_DOUBLE_EQ(d.sigma_a[2], 0.6 * 3.0 + 0.4 * 0.5);
  // each lobe carries w_i sigma_s_i and its own g
  EXPECT_DOUBLE_EQ(d.lobes[0].sigma_s[1], 0.6 * 40.0);
  EXPECT_DOUBLE_EQ(d.lobes[1].sigma_s[1], 0.4 * 20.0);
  EXPECT_DOUBLE_EQ(d.lobes[1].g[2], 0.7);
  EXPECT_DOUBLE_EQ(d.sigma_s()[2], 0.6 * 40.0 + 0.4 * 30.0);
  // sigma_s p = sum w_i sigma_s_i p_HG(g_i), so p is the scattering-weighted mixture.
  for (int c = 0; c < kChannels; ++c) {
    for (double mu : {-1.0, -0.3, 0.0, 0.5, 1.0}) {
      const double ss0 = 0.6 * 40.0, ss1 = 0.4 * Spectrum(10.0, 20.0, 30.0)[c];
      const double expect = (ss0 * henyey_greenstein(mu, 0.0) +
                             ss1 * henyey_greenstein(mu, Spectrum(0.9, 0.8, 0.7)[c])) / (ss0 + ss1);
      EXPECT_NEAR(d.phase(c, mu), expect, 1e-14 * expect);
    }
  }
}

TEST(StackFile, ContractExampleRoundTrip) {
  const LayerStack s = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/contract_leaf.json");
  EXPECT_EQ(s.name, "leaf");
  EXPECT_EQ(s.above_ior, 1.0);
  ASSERT_EQ(s.layers.size(), 2u);
  const Layer& e = s.layers[0];
  EXPECT_EQ(e.name, "epidermis");
  EXPECT_EQ(e.ior, 1.45);
  EXPECT_EQ(e.thickness, 0.05);
  EXPECT_EQ(e.sigma_a, Spectrum(0.4, 0.1, 0.9));
  ASSERT_EQ(e.lobes.size(), 1u);
  EXPECT_EQ(e.lobes[0].sigma_s, Spectrum(30.0));
  EXPECT_EQ(e.lobes[0].g, Spectrum(0.2));
  const Layer& m = s.layers[1];
  EXPECT_EQ(m.name, "mesophyll");
  EXPECT_EQ(m.thickness, 0.15);
  ASSERT_EQ(m.lobes.size(), 2u);
  EXPECT_DOUBLE_EQ(m.sigma_a[0], 0.7 * 1.2);
  EXPECT_DOUBLE_EQ(m.sigma_a[2], 0.7 * 2.0);
  EXPECT_DOUBLE_EQ(m.lobes[0].sigma_s[0], 0.7 * 40.0);
  EXPECT_DOUBLE_EQ(m.lobes[1].sigma_s[0], 0.3 * 80.0);
  EXPECT_EQ(m.lobes[1].g, Spectrum(0.9));
  EXPECT_EQ(s.below.kind, Below::Kind::Dielectric);
  EXPECT_EQ(s.below.ior, 1.0);
  EXPECT_TRUE(s.transmits());
}

TEST(StackFile, DefaultsAndInfiniteLastLayer) {
  const LayerStack s = parse_stack_json(R"({"lamina_material": 1, "layers": [
      {"ior": 1.3, "thickness": "inf", "sigma_a": 0.1, "sigma_s": 1, "g": -0.5}]})", "x.json");
  EXPECT_EQ(s.above_ior, 1.0);
  EXPECT_EQ(s.below.kind, Below::Kind::Dielectric);
  EXPECT_EQ(s.below.ior, 1.0);
  EXPECT_TRUE(s.layers[0].semi_infinite());
  EXPECT_FALSE(s.transmits());
}

// One test per kind of error.
TEST(StackFileErrors, MalformedJsonNamesLineAndColumn) {
  expect_error(R"({"lamina_material": 1,
  "layers": [ }")", "(document)", "line 2");
}
TEST(StackFileErrors, TruncatedJson) {
  const std::string text = kGood;
  expect_error(text.substr(0, text.size() / 2), "(document)", "malformed JSON");
}
TEST(StackFileErrors, RootNotObject) { expect_error("[1, 2]", "(document)", "expected an object"); }
TEST(StackFileErrors, MissingFile) {
  try {
    load_stack_file("/nonexistent/dir/skin.json");
    ADD_FAILURE() << "accepted a missing file";
  } catch (const StackFileError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("/nonexistent/dir/skin.json: ", 0), 0u) << msg;
    EXPECT_NE(msg.find("cannot read the material file: does not exist"), std::string::npos) << msg;
  }
  // A directory says so.
  try {
    load_stack_file("/");
    ADD_FAILURE() << "accepted a directory";
  } catch (const StackFileError& e) {
    EXPECT_NE(std::string(e.what()).find("/: cannot read the material file: is a directory"), std::string::npos) << e.what();
  }
}
TEST(StackFileErrors, DirectoryInsteadOfFile) {
  try {
    load_stack_file(LAMINA_SOURCE_DIR);
    ADD_FAILURE() << "accepted a directory";
  } catch (const StackFileError& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
}
TEST(StackFileErrors, EmptyFileText) { expect_error("", "(document)", "malformed JSON"); }
TEST(StackValidation, NamesThePathOfTheBadValue) {
  LayerStack s = parse_stack_json(kGood, "skin.json");
  s.layers[1].lobes[1].g[2] = 1.0;
  EXPECT_EQ(validate_stack(s), "layers[1].components[1].g[2]: must satisfy |g| < 1");
  s = parse_stack_json(kGood, "skin.json");
  s.layers[0].sigma_a[1] = -1.0;
  EXPECT_EQ(validate_stack(s).rfind("layers[0].sigma_a[1]: must be finite and >= 0", 0), 0u);
  s = parse_stack_json(kGood, "skin.json");
  s.layers[0].thickness = kInfiniteThickness;
  EXPECT_EQ(validate_stack(s).rfind("layers[0].thickness: only the last layer", 0), 0u);
}
TEST(StackFileErrors, MissingVersion) {
  expect_error(replaced(kGood, "\"lamina_material\": 1,", ""), "lamina_material", "missing required key");
}
TEST(StackFileErrors, WrongVersion) {
  expect_error(replaced(kGood, "\"lamina_material\": 1", "\"lamina_material\": 2"), "lamina_material",
               "unsupported version");
}
TEST(StackFileErrors, MissingLayers) {
  expect_error(R"({"lamina_material": 1})", "layers", "missing required key");
}
TEST(StackFileErrors, EmptyLayers) {
  expect_error(R"({"lamina_material": 1, "layers": []})", "layers", "at least one layer");
}
TEST(StackFileErrors, MissingLayerKey) {
  expect_error(replaced(kGood, "\"sigma_s\": 30.0,", ""), "layers[0].sigma_s", "missing required key");
}
TEST(StackFileErrors, MissingIor) {
  expect_error(replaced(kGood, "\"ior\": 1.4, \"thickness\": 1.0", "\"thickness\": 1.0"),
               "layers[1].ior", "missing required key");
}
TEST(StackFileErrors, MissingComponentKey) {
  expect_error(replaced(kGood, "\"fraction\": 0.6, ", ""), "layers[1].components[0].fraction",
               "missing required key");
}
TEST(StackFileErrors, WrongTypeString) {
  expect_error(replaced(kGood, "\"sigma_s\": 30.0", "\"sigma_s\": \"30\""), "layers[0].sigma_s",
               "got a string");
}
TEST(StackFileErrors, WrongTypeName) {
  expect_error(replaced(kGood, "\"name\": \"skin\"", "\"name\": 3"), "name", "expected a string");
}
TEST(StackFileErrors, WrongArrayLength) {
  expect_error(replaced(kGood, "[0.4, 0.1, 0.9]", "[0.4, 0.1]"), "layers[0].sigma_a",
               "array of 2");
}
TEST(StackFileErrors, WrongTypeInArray) {
  expect_error(replaced(kGood, "[0.4, 0.1, 0.9]", "[0.4, null, 0.9]"), "layers[0].sigma_a[1]",
               "expected a number");
}
TEST(StackFileErrors, NegativeCoefficient) {
  expect_error(replaced(kGood, "[0.4, 0.1, 0.9]", "[0.4, -0.1, 0.9]"), "layers[0].sigma_a[1]",
               "must be >= 0");
}
TEST(StackFileErrors, NegativeComponentCoefficient) {
  expect_error(replaced(kGood, "\"sigma_s\": 40.0", "\"sigma_s\": -40.0"),
               "layers[1].components[0].sigma_s", "must be >= 0");
}
TEST(StackFileErrors, NonFiniteCoefficient) {
  // 1e999 overflows a double: nlohmann refuses it while parsing; the error names the JSON path
  // where the parser was and the literal, in our words, not the library's.
  expect_error(replaced(kGood, "\"sigma_s\": 30.0", "\"sigma_s\": 1e999"), "layers[0].sigma_s",
               "number '1e999' is too large for a double");
}
// Each coefficient is finite but their sum is not: the albedo sigma_s / sigma_t would be 0.
TEST(StackFileErrors, CoefficientsSumPastTheLargestDouble) {
  expect_error(replaced(kGood, "\"sigma_a\": [0.4, 0.1, 0.9], \"sigma_s\": 30.0",
                        "\"sigma_a\": [0.4, 1e308, 0.9], \"sigma_s\": 1e308"),
               "layers[0]", "sigma_a + sigma_s must be at most 1.79769e+308 (the largest double; channel 1 overflows)");
  LayerStack s = parse_stack_json(kGood, "skin.json");
  s.layers[1].lobes[0].sigma_s = Spectrum(1.5e308);
  s.layers[1].lobes[1].sigma_s = Spectrum(1.5e308);
  EXPECT_EQ(validate_stack(s).rfind("layers[1]: sigma_a + sigma_s must be at most", 0), 0u) << validate_stack(s);
}
TEST(StackFileErrors, GTooLarge) {
  expect_error(replaced(kGood, "\"g\": 0.2", "\"g\": 1.0"), "layers[0].g", "|g| < 1");
}
TEST(StackFileErrors, GTooNegativeInArray) {
  expect_error(replaced(kGood, "[0.9, 0.8, 0.7]", "[0.9, -1.5, 0.7]"),
               "layers[1].components[1].g[1]", "|g| < 1");
}
TEST(StackFileErrors, IorZero) {
  expect_error(replaced(kGood, "\"ior\": 1.4, \"thickness\": 0.1", "\"ior\": 0, \"thickness\": 0.1"),
               "layers[0].ior", "must be > 0");
}
TEST(StackFileErrors, AboveIorNegative) {
  expect_error(replaced(kGood, "\"above_ior\": 1.0", "\"above_ior\": -1.0"), "above_ior", "must be > 0");
}
TEST(StackFileErrors, BelowIorZero) {
  expect_error(replaced(kGood, "{ \"lambert\": [0.5, 0.4, 0.3] }", "{ \"ior\": 0.0 }"), "below.ior",
               "must be > 0");
}
TEST(StackFileErrors, NegativeThickness) {
  expect_error(replaced(kGood, "\"thickness\": 0.1", "\"thickness\": -0.1"), "layers[0].thickness",
               "must be >= 0");
}
TEST(StackFileErrors, BadThicknessString) {
  expect_error(replaced(kGood, "\"thickness\": 1.0", "\"thickness\": \"infinite\""),
               "layers[1].thickness", "\"inf\"");
}
TEST(StackFileErrors, InfiniteLayerNotLast) {
  expect_error(replaced(kGood, "\"thickness\": 0.1", "\"thickness\": \"inf\""), "layers[0].thickness",
               "only the last layer");
}
TEST(StackFileErrors, ClearSemiInfiniteLayer) {
  expect_error(R"({"lamina_material": 1, "layers": [
      {"ior": 1.3, "thickness": "inf", "sigma_a": 0, "sigma_s": [1, 0, 1], "g": 0}]})",
               "layers[0]", "semi-infinite layer needs sigma_a + sigma_s > 0");
}
TEST(StackFileErrors, NegativeFraction) {
  expect_error(replaced(replaced(kGood, "\"fraction\": 0.6", "\"fraction\": -0.6"), "\"fraction\": 0.4",
                        "\"fraction\": 1.6"),
               "layers[1].components[0].fraction", "must be >= 0");
}
TEST(StackFileErrors, FractionsDoNotSumToOne) {
  expect_error(replaced(kGood, "\"fraction\": 0.4", "\"fraction\": 0.3"), "layers[1].components[1].fraction",
               "fractions must sum to 1 (sum 0.9)");
}
TEST(StackFileErrors, FractionsWithinToleranceAccepted) {
  // 1e-6 is the contract's tolerance: 0.4 + 0.5e-6 passes, 0.4 + 2e-6 fails.
  EXPECT_NO_THROW(parse_stack_json(replaced(kGood, "\"fraction\": 0.4", "\"fraction\": 0.4000005"), "s"));
  expect_error(replaced(kGood, "\"fraction\": 0.4", "\"fraction\": 0.400002"),
               "layers[1].components[1].fraction", "sum to 1");
}
TEST(StackFileErrors, BothDirectAndComponents) {
  expect_error(replaced(kGood, "\"thickness\": 1.0,", "\"thickness\": 1.0, \"g\": 0.1,"), "layers[1]",
               "not both");
}
TEST(StackFileErrors, EmptyComponents) {
  expect_error(R"({"lamina_material": 1, "layers": [{"ior": 1, "thickness": 1, "components": []}]})",
               "layers[0].components", "at least one component");
}
TEST(StackFileErrors, UnknownTopLevelKey) {
  expect_error(replaced(kGood, "\"above_ior\"", "\"abov_ior\""), "abov_ior", "unknown key");
}
TEST(StackFileErrors, UnknownLayerKey) {
  expect_error(replaced(kGood, "\"sigma_s\": 30.0", "\"sigma_t\": 30.0"), "layers[0].sigma_t", "unknown key");
}
TEST(StackFileErrors, UnknownComponentKey) {
  expect_error(replaced(kGood, "\"fraction\": 0.6", "\"fraction\": 0.6, \"colour\": 1"),
               "layers[1].components[0].colour", "unknown key");
}
TEST(StackFileErrors, UnknownBelowKey) {
  expect_error(replaced(kGood, "{ \"lambert\"", "{ \"lamber\""), "below.lamber", "unknown key");
}
TEST(StackFileErrors, BelowBothKinds) {
  expect_error(replaced(kGood, "{ \"lambert\"", "{ \"ior\": 1.0, \"lambert\""), "below", "not both");
}
TEST(StackFileErrors, BelowEmpty) {
  expect_error(replaced(kGood, "{ \"lambert\": [0.5, 0.4, 0.3] }", "{}"), "below", "expected");
}
TEST(StackFileErrors, AlbedoAboveOne) {
  expect_error(replaced(kGood, "[0.5, 0.4, 0.3]", "[0.5, 1.2, 0.3]"), "below.lambert[1]", "[0, 1]");
}
TEST(StackFileErrors, AlbedoNegative) {
  expect_error(replaced(kGood, "[0.5, 0.4, 0.3]", "-0.1"), "below.lambert", "[0, 1]");
}

TEST(StackFlip, ReversesLayersAndSwapsMedia) {
  LayerStack s = parse_stack_json(replaced(kGood, "{ \"lambert\": [0.5, 0.4, 0.3] }", "{ \"ior\": 1.33 }"),
                                  "skin.json");
  s.above_ior = 1.1;
  const LayerStack f = flipped(s);
  EXPECT_EQ(f.above_ior, 1.33);
  EXPECT_EQ(f.below.ior, 1.1);
  ASSERT_EQ(f.layers.size(), 2u);
  EXPECT_EQ(f.layers[0].name, "dermis");
  EXPECT_EQ(f.layers[1].name, "epidermis");
  const LayerStack ff = flipped(f);
  EXPECT_EQ(ff.above_ior, s.above_ior);
  EXPECT_EQ(ff.layers[0].name, "epidermis");
  EXPECT_TRUE(validate_stack(f).empty());
}

TEST(StackFlip, RejectsOpaqueStacks) {
  const LayerStack s = parse_stack_json(kGood, "skin.json");  // Lambert below
  EXPECT_THROW(flipped(s), std::invalid_argument);
}


// A leaf-like transmitting stack with a diffuse top and a diffuse interface below the cuticle:
// the flags come back from a file on disk, count only where the index steps, and enter the
// fingerprint.
const char* kDiffuse = R"({
  "lamina_material": 1,
  "top_diffuse": true,
  "layers": [
    { "name": "cuticle", "ior": 1.5, "thickness": 0.01, "sigma_a": 0.1, "sigma_s": 0, "g": 0, "bottom_diffuse": true },
    { "name": "mesophyll", "ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 20, "g": 0.5, "bottom_diffuse": false },
    { "name": "lower", "ior": 1.4, "thickness": 0.1, "sigma_a": 0.5, "sigma_s": 20, "g": 0.5, "bottom_diffuse": true }
  ],
  "below": { "ior": 1.0 }
})";

TEST(StackFileDiffuse, FlagsRoundTripThroughAFile) {
  const std::string path = ::testing::TempDir() + "/diffuse_stack.json";
  {
    std::ofstream out(path);
    out << kDiffuse;
  }
  const LayerStack s = load_stack_file(path);
  std::remove(path.c_str());
  EXPECT_TRUE(s.top_diffuse);
  EXPECT_TRUE(s.layers[0].bottom_diffuse);
  EXPECT_FALSE(s.layers[1].bottom_diffuse);
  EXPECT_TRUE(s.layers[2].bottom_diffuse);
  EXPECT_TRUE(s.diffuse_interface(0));
  EXPECT_TRUE(s.diffuse_interface(1));   // 1.5 | 1.4
  EXPECT_FALSE(s.diffuse_interface(2));  // not flagged
  EXPECT_TRUE(s.diffuse_interface(3));   // 1.4 | air
  EXPECT_EQ(s.first_diffuse_interface_path(), "top_diffuse");
  EXPECT_TRUE(validate_stack(s).empty());
  // Without the flags: the same file as before the keys existed, and another fingerprint.
  LayerStack plain = s;
  plain.top_diffuse = false;
  for (Layer& l : plain.layers) l.bottom_diffuse = false;
  EXPECT_FALSE(plain.any_diffuse_interface());
  EXPECT_EQ(plain.first_diffuse_interface_path(), "");
  EXPECT_NE(stack_fingerprint(s), stack_fingerprint(plain));
  LayerStack bottom_only = plain;
  bottom_only.layers[2].bottom_diffuse = true;
  EXPECT_EQ(bottom_only.first_diffuse_interface_path(), "layers[2].bottom_diffuse");
  EXPECT_NE(stack_fingerprint(bottom_only), stack_fingerprint(plain));
  EXPECT_NE(stack_fingerprint(bottom_only), stack_fingerprint(s));
}

TEST(StackFileDiffuse, IndexMatchedInterfaceIsNotDiffuse) {
  LayerStack s = parse_stack_json(kDiffuse, "leaf.json");
  s.layers[0].ior = 1.4;  // cuticle | mesophyll matched: no interface there
  EXPECT_FALSE(s.diffuse_interface(1));
  s.above_ior = 1.4;
  EXPECT_FALSE(s.diffuse_interface(0));
  EXPECT_EQ(s.first_diffuse_interface_path(), "layers[2].bottom_diffuse");
}

TEST(StackFileDiffuse, FlipMovesTheFlags) {
  LayerStack s = parse_stack_json(kDiffuse, "leaf.json");
  s.layers[2].bottom_diffuse = false;  // top diffuse, bottom smooth: the flip swaps them
  const LayerStack f = flipped(s);
  EXPECT_FALSE(f.top_diffuse);
  EXPECT_TRUE(f.layers[2].bottom_diffuse);  // the old top
  EXPECT_TRUE(f.layers[1].bottom_diffuse);  // the old interface below the cuticle (now above it)
  EXPECT_FALSE(f.layers[0].bottom_diffuse);
  for (int k = 0; k <= 3; ++k) EXPECT_EQ(f.diffuse_interface(k), s.diffuse_interface(3 - k)) << k;
  EXPECT_EQ(stack_fingerprint(flipped(f)), stack_fingerprint(s));
  LayerStack into;
  flip_into(s, &into);
  EXPECT_EQ(stack_fingerprint(into), stack_fingerprint(f));
}

TEST(StackFileDiffuseErrors, NotABoolean) {
  expect_error(replaced(kDiffuse, "\"top_diffuse\": true", "\"top_diffuse\": 1"), "top_diffuse", "expected a boolean");
  expect_error(replaced(kDiffuse, "\"bottom_diffuse\": false", "\"bottom_diffuse\": \"no\""), "layers[1].bottom_diffuse",
               "expected a boolean");
}
TEST(StackFileDiffuseErrors, DiffuseAndRough) {
  expect_error(replaced(kDiffuse, "\"top_diffuse\": true", "\"top_diffuse\": true, \"roughness\": 0.3"), "top_diffuse",
               "cannot also be rough");
  expect_error(replaced(kDiffuse, "\"bottom_diffuse\": true }", "\"bottom_diffuse\": true, \"bottom_roughness\": 0.2 }"),
               "layers[0].bottom_diffuse", "cannot also be rough");
}
TEST(StackFileDiffuseErrors, NoBottomInterface) {
  expect_error(replaced(kDiffuse, "{ \"ior\": 1.0 }", "{ \"lambert\": 0.5 }"), "layers[2].bottom_diffuse",
               "no bottom interface");
}

}  // namespace
}  // namespace lamina
