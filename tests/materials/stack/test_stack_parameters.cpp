// Stack parameters: setting a value through a parameter path gives the same stack as writing
// that value into the material file (the file reader is the independent reference), fractions
// keep summing to 1, clamping keeps stacks valid, and bad paths are rejected with clear errors.
#include "materials/stack/stack_parameters.h"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string preset(const std::string& name) { return std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/" + name; }

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

std::string replaced(std::string text, const std::string& from, const std::string& to, int occurrence = 0) {
  std::size_t at = text.find(from);
  for (int i = 0; i < occurrence && at != std::string::npos; ++i) at = text.find(from, at + 1);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not found";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Relative tolerance 4 ulps-ish: the two paths sum the same products in the same order, so they
// agree to rounding of the fractions (which are computed, then printed with 17 digits).
void expect_same_stack(const LayerStack& a, const LayerStack& b) {
  EXPECT_EQ(a.top_roughness, b.top_roughness);
  ASSERT_EQ(a.layers.size(), b.layers.size());
  EXPECT_EQ(a.above_ior, b.above_ior);
  EXPECT_EQ(a.below.kind, b.below.kind);
  EXPECT_EQ(a.below.ior, b.below.ior);
  for (int c = 0; c < kChannels; ++c) EXPECT_DOUBLE_EQ(a.below.albedo[c], b.below.albedo[c]);
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    const Layer& x = a.layers[i];
    const Layer& y = b.layers[i];
    SCOPED_TRACE("layer " + std::to_string(i));
    EXPECT_EQ(x.ior, y.ior);
    EXPECT_EQ(x.thickness, y.thickness);
    ASSERT_EQ(x.lobes.size(), y.lobes.size());
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_DOUBLE_EQ(x.sigma_a[c], y.sigma_a[c]);
      for (std::size_t k = 0; k < x.lobes.size(); ++k) {
        EXPECT_DOUBLE_EQ(x.lobes[k].sigma_s[c], y.lobes[k].sigma_s[c]);
        EXPECT_EQ(x.lobes[k].g[c], y.lobes[k].g[c]);
      }
    }
  }
}

LayerStack applied(const StackTemplate& t, const std::vector<std::string>& paths, const std::vector<Spectrum>& values) {
  std::vector<StackParameter> ps;
  for (const std::string& p : paths) ps.push_back(parse_stack_parameter(t, p));
  check_parameter_set(ps);
  LayerStack out;
  apply_parameters(t, ps, values.data(), &out);
  EXPECT_EQ(validate_stack(out), "");
  return out;
}

TEST(StackParameters, NoParametersGiveTheTemplate) {
  const StackTemplate t = load_stack_template(preset("skin_oily.json"));
  expect_same_stack(applied(t, {}, {}), t.stack);
  expect_same_stack(t.stack, load_stack_file(preset("skin_oily.json")));
}

TEST(StackParameters, BloodFractionEqualsTheFileWithThatFraction) {
  const std::string text = read_text(preset("skin.json"));
  const StackTemplate t = parse_stack_template_json(text, "skin.json");
  for (double f : {0.0, 0.005, 0.05, 0.3, 1.0}) {
    SCOPED_TRACE("blood fraction " + std::to_string(f));
    // The other dermis component scales by (1 - f) / (1 - 0.02) (stack_parameters.h).
    const double other = 0.98 * (1.0 - f) / 0.98;
    std::string edited = replaced(text, "\"fraction\": 0.02", "\"fraction\": " + num(f), 1);
    edited = replaced(edited, "\"fraction\": 0.98", "\"fraction\": " + num(other), 1);
    const LayerStack expected = parse_stack_json(edited, "edited skin.json");
    expect_same_stack(applied(t, {"layers[1].components[0].fraction"}, {Spectrum(f)}), expected);
  }
}

TEST(StackParameters, OtherFractionsKeepTheirProportions) {
  const std::string text = R"({"lamina_material": 1, "layers": [
    {"ior": 1.4, "thickness": 1.0, "components": [
      {"fraction": 0.2, "sigma_a": 1.0, "sigma_s": 10.0, "g": 0.1},
      {"fraction": 0.5, "sigma_a": 2.0, "sigma_s": 20.0, "g": 0.5},
      {"fraction": 0.3, "sigma_a": 3.0, "sigma_s": 30.0, "g": 0.9}]}]})";
  const StackTemplate t = parse_stack_template_json(text, "three.json");
  const LayerStack s = applied(t, {"layers[0].components[1].fraction"}, {Spectrum(0.9)});
  // Others had 0.5 in total; they share 0.1 as 0.2:0.3, i.e. 0.04 and 0.06.
  EXPECT_NEAR(s.layers[0].lobes[0].sigma_s[0], 0.04 * 10.0, 1e-14);
  EXPECT_NEAR(s.layers[0].lobes[1].sigma_s[0], 0.9 * 20.0, 1e-13);
  EXPECT_NEAR(s.layers[0].lobes[2].sigma_s[0], 0.06 * 30.0, 1e-14);
  EXPECT_NEAR(s.layers[0].sigma_a[0], 0.04 * 1.0 + 0.9 * 2.0 + 0.06 * 3.0, 1e-14);
}

TEST(StackParameters, OthersWithZeroFractionShareTheRestEqually) {
  const std::string text = R"({"lamina_material": 1, "layers": [
    {"ior": 1.4, "thickness": 1.0, "components": [
      {"fraction": 1.0, "sigma_a": 1.0, "sigma_s": 10.0, "g": 0.0},
      {"fraction": 0.0, "sigma_a": 2.0, "sigma_s": 20.0, "g": 0.0},
      {"fraction": 0.0, "sigma_a": 4.0, "sigma_s": 40.0, "g": 0.0}]}]})";
  const StackTemplate t = parse_stack_template_json(text, "zero.json");
  const LayerStack s = applied(t, {"layers[0].components[0].fraction"}, {Spectrum(0.4)});
  EXPECT_NEAR(s.layers[0].sigma_a[1], 0.4 * 1.0 + 0.3 * 2.0 + 0.3 * 4.0, 1e-14);
  EXPECT_NEAR(s.layers[0].sigma_s()[2], 0.4 * 10.0 + 0.3 * 20.0 + 0.3 * 40.0, 1e-13);
}

TEST(StackParameters, OilThicknessEqualsTheFileWithThatThickness) {
  const std::string text = read_text(preset("skin_oily.json"));
  const StackTemplate t = parse_stack_template_json(text, "skin_oily.json");
  for (double d : {0.0, 0.001, 0.02}) {
    const LayerStack expected =
        parse_stack_json(replaced(text, "\"thickness\": 0.005", "\"thickness\": " + num(d)), "edited");
    expect_same_stack(applied(t, {"layers[0].thickness"}, {Spectrum(d)}), expected);
  }
}

TEST(StackParameters, RoughnessEqualsTheFileWithThatRoughness) {
  const std::string text = read_text(preset("skin_oily.json"));
  const StackTemplate t = parse_stack_template_json(text, "skin_oily.json");
  for (double a : {0.0, 0.2, 1.0}) {
    const LayerStack expected = parse_stack_json(replaced(text, "\"roughness\": 0.4", "\"roughness\": " + num(a)), "edited");
    const LayerStack s = applied(t, {"roughness"}, {Spectrum(a)});
    expect_same_stack(s, expected);
    EXPECT_EQ(s.top_roughness, a);
  }
  EXPECT_EQ(applied(t, {"roughness"}, {Spectrum(3.0)}).top_roughness, 1.0);  // clamped
  // A transmitting stack cannot have a single-scattering rough top; the energy-conserving one
  // (the default) it can.
  StackTemplate leaf = load_stack_template(preset("leaf.json"));
  EXPECT_EQ(parse_stack_parameter(leaf, "roughness").kind, StackParameter::Kind::kRoughness);
  leaf.stack.interface_model = InterfaceModel::SingleScattering;
  EXPECT_THROW(parse_stack_parameter(leaf, "roughness"), StackParameterError);
}

TEST(StackParameters, SeveralParametersTogetherEqualTheEditedFile) {
  // Melanin fraction (epidermis), blood fraction (dermis), oil thickness and ior, flesh colour.
  const std::string text = read_text(preset("skin_oily.json"));
  const StackTemplate t = parse_stack_template_json(text, "skin_oily.json");
  std::string e = replaced(text, "\"thickness\": 0.005", "\"thickness\": 0.01");
  e = replaced(e, "\"ior\": 1.47", "\"ior\": 1.5");
  e = replaced(e, "\"fraction\": 0.02", "\"fraction\": 0.1", 0);
  e = replaced(e, "\"fraction\": 0.98", "\"fraction\": " + num(0.98 * 0.9 / 0.98), 0);
  // The epidermis' fractions are replaced above, so the dermis' are now the first occurrences.
  e = replaced(e, "\"fraction\": 0.02", "\"fraction\": 0.04", 0);
  e = replaced(e, "\"fraction\": 0.98", "\"fraction\": " + num(0.98 * 0.96 / 0.98), 0);
  e = replaced(e, "\"lambert\": [\n      0.8,\n      0.55,\n      0.45\n    ]", "\"lambert\": [0.7, 0.5, 0.4]");
  const LayerStack s = applied(t,
                               {"layers[0].thickness", "layers[0].ior", "layers[1].components[0].fraction",
                                "layers[2].components[0].fraction", "below.lambert"},
                               {Spectrum(0.01), Spectrum(1.5), Spectrum(0.1), Spectrum(0.04), Spectrum(0.7, 0.5, 0.4)});
  expect_same_stack(s, parse_stack_json(e, "edited"));
}

TEST(StackParameters, ColoursOfDirectLayersAndComponents) {
  const std::string text = R"({"lamina_material": 1, "layers": [
    {"ior": 1.45, "thickness": 0.05, "sigma_a": [0.4, 0.1, 0.9], "sigma_s": 30.0, "g": 0.2},
    {"ior": 1.45, "thickness": 0.15, "components": [
      {"fraction": 0.7, "sigma_a": [1.2, 0.3, 2.0], "sigma_s": 40.0, "g": 0.0},
      {"fraction": 0.3, "sigma_a": 0.0, "sigma_s": 80.0, "g": 0.9}]}], "below": {"ior": 1.0}})";
  const StackTemplate t = parse_stack_template_json(text, "leaf.json");
  std::string e = replaced(text, "\"sigma_a\": [0.4, 0.1, 0.9]", "\"sigma_a\": [1, 2, 3]");
  e = replaced(e, "\"g\": 0.2", "\"g\": -0.5");
  e = replaced(e, "\"sigma_s\": 80.0", "\"sigma_s\": [5, 6, 7]");
  const LayerStack s = applied(t, {"layers[0].sigma_a", "layers[0].g", "layers[1].components[1].sigma_s"},
                               {Spectrum(1, 2, 3), Spectrum(-0.5), Spectrum(5, 6, 7)});
  expect_same_stack(s, parse_stack_json(e, "edited"));
  const LayerStack n = applied(t, {"below.ior"}, {Spectrum(1.33)});
  EXPECT_EQ(n.below.ior, 1.33);
}

TEST(StackParameters, ValuesOutsideTheRangeAreClampedToValidStacks) {
  const StackTemplate t = load_stack_template(preset("skin_oily.json"));
  const double nan = std::nan("");
  const LayerStack s = applied(
      t, {"layers[1].components[0].fraction", "layers[2].components[1].g", "layers[0].thickness", "below.lambert"},
      {Spectrum(1.5), Spectrum(1.0, -3.0, nan), Spectrum(-1.0), Spectrum(2.0, -1.0, 0.5)});
  // Fraction 1: the melanin component alone, the other at 0.
  EXPECT_DOUBLE_EQ(s.layers[1].sigma_a[0], 28.35);
  EXPECT_EQ(s.layers[0].thickness, 0.0);
  EXPECT_LT(s.layers[2].lobes[1].g[0], 1.0);
  EXPECT_GT(s.layers[2].lobes[1].g[1], -1.0);
  EXPECT_EQ(s.layers[2].lobes[1].g[2], 0.0);  // NaN becomes 0
  EXPECT_EQ(s.below.albedo, Spectrum(1.0, 0.0, 0.5));
}

TEST(StackParameters, ReusingTheOutputStackLeavesNothingBehind) {
  const StackTemplate t = load_stack_template(preset("skin_oily.json"));
  std::vector<StackParameter> ps = {parse_stack_parameter(t, "layers[2].components[0].fraction"),
                                    parse_stack_parameter(t, "layers[0].thickness")};
  LayerStack scratch;
  const Spectrum a[2] = {Spectrum(0.5), Spectrum(0.1)};
  const Spectrum b[2] = {Spectrum(0.01), Spectrum(0.002)};
  apply_parameters(t, ps, a, &scratch);
  apply_parameters(t, ps, b, &scratch);
  LayerStack fresh;
  apply_parameters(t, ps, b, &fresh);
  expect_same_stack(scratch, fresh);
}

TEST(StackParameters, ScalarAndSpectralKindsAndRanges) {
  const StackTemplate t = load_stack_template(preset("skin_oily.json"));
  const StackParameter f = parse_stack_parameter(t, "layers[2].components[0].fraction");
  EXPECT_FALSE(f.spectral());
  EXPECT_EQ(f.min_value(), 0.0);
  EXPECT_EQ(f.max_value(), 1.0);
  EXPECT_EQ(f.template_value(t), Spectrum(0.02));
  const StackParameter sa = parse_stack_parameter(t, "layers[1].components[0].sigma_a");
  EXPECT_TRUE(sa.spectral());
  EXPECT_EQ(sa.template_value(t), Spectrum(28.35, 49.45, 96.46));
  EXPECT_EQ(parse_stack_parameter(t, "layers[0].thickness").template_value(t), Spectrum(0.005));
}

void expect_bad_path(const StackTemplate& t, const std::string& path, const std::string& reason) {
  try {
    parse_stack_parameter(t, path);
    ADD_FAILURE() << "accepted '" << path << "'";
  } catch (const StackParameterError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << m;
    EXPECT_NE(m.find(reason), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

TEST(StackParameters, InvalidPathsAreRejectedWithTheReason) {
  const StackTemplate t = load_stack_template(preset("skin_oily.json"));
  expect_bad_path(t, "layers[3].thickness", "has 3 layer(s)");
  expect_bad_path(t, "layers[1].components[2].fraction", "has 2 component(s)");
  expect_bad_path(t, "layers[0].components[0].fraction", "has no components");
  expect_bad_path(t, "layers[1].sigma_a", "bind layers[1].components[j].sigma_a");
  expect_bad_path(t, "layers[1].components[0].fration", "unknown key 'fration'");
  expect_bad_path(t, "layers[1].thicknes", "unknown key 'thicknes'");
  expect_bad_path(t, "layers[-1].thickness", "non-negative integer");
  expect_bad_path(t, "layers[x].thickness", "non-negative integer");
  expect_bad_path(t, "layers[1", "missing ']'");
  expect_bad_path(t, "layers.1.thickness", "expected '['");
  expect_bad_path(t, "layers[1]", "expected '.'");
  expect_bad_path(t, "dermis.blood", "expected roughness, or a path starting with layers[i] or below");
  expect_bad_path(t, "below.ior", "a Lambert substrate, not a dielectric");
  expect_bad_path(t, "", "a path starting with layers");
  const StackTemplate one = parse_stack_template_json(
      R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": "inf", "components": [
         {"fraction": 1.0, "sigma_a": 1.0, "sigma_s": 1.0, "g": 0.0}]}], "below": {"ior": 1.0}})",
      "one.json");
  expect_bad_path(one, "layers[0].components[0].fraction", "only component always has fraction 1");
  expect_bad_path(one, "layers[0].thickness", "semi-infinite");
  expect_bad_path(one, "below.lambert", "is a dielectric");
}

TEST(StackParameters, AmbiguousSetsAreRejected) {
  const StackTemplate t = load_stack_template(preset("skin.json"));
  const StackParameter a = parse_stack_parameter(t, "layers[1].components[0].fraction");
  const StackParameter b = parse_stack_parameter(t, "layers[1].components[1].fraction");
  const StackParameter c = parse_stack_parameter(t, "layers[0].components[0].fraction");
  EXPECT_THROW(check_parameter_set({a, a}), StackParameterError);
  EXPECT_THROW(check_parameter_set({a, b}), StackParameterError);
  EXPECT_NO_THROW(check_parameter_set({a, c}));
}

// The syntax batch manifests' "set" paths share (split_stack_path), and walking a file's JSON.
// A chromophore layer's melanin and blood (layers[i].chromophores.KEY): the stack equals, bit
// for bit, the file with that value, the baseline giving way by the difference (b = b0 - (x - x0),
// stack_parameters.cpp): the reader and the binding compute the RGB coefficients by the same
// function of the same numbers. A share (eumelanin) leaves the baseline alone.
TEST(StackParameters, ChromophoresEqualTheFileWithThatValue) {
  const std::string text = read_text(std::string(LAMINA_SOURCE_DIR) + "/scenes/spectral/skin_spectral.json");
  const StackTemplate t = parse_stack_template_json(text, "skin_spectral.json");
  for (double m : {0.0, 0.01, 0.03, 0.2, 0.5}) {
    SCOPED_TRACE("melanin " + std::to_string(m));
    std::string edited = replaced(text, "\"melanin\": 0.03", "\"melanin\": " + num(m));
    edited = replaced(edited, "\"baseline\": 0.97", "\"baseline\": " + num(std::max(0.0, 0.97 - (m - 0.03))));
    const LayerStack got = applied(t, {"layers[0].chromophores.melanin"}, {Spectrum(m)});
    const LayerStack expected = parse_stack_json(edited, "edited");
    EXPECT_EQ(got.layers[0].sigma_a, expected.layers[0].sigma_a);
    expect_same_stack(got, expected);
  }
  for (double b : {0.0, 0.005, 0.02, 0.02 + 1e-9, 0.04}) {
    SCOPED_TRACE("blood " + std::to_string(b));
    std::string edited = replaced(text, "\"blood\": 0.02", "\"blood\": " + num(b));
    edited = replaced(edited, "\"baseline\": 0.38", "\"baseline\": " + num(std::max(0.0, 0.38 - (b - 0.02))));
    const LayerStack got = applied(t, {"layers[1].chromophores.blood", "layers[0].chromophores.eumelanin"},
                                   {Spectrum(b), Spectrum(0.4)});
    edited = replaced(edited, "\"eumelanin\": 0.7", "\"eumelanin\": 0.4");
    const LayerStack expected = parse_stack_json(edited, "edited");
    EXPECT_EQ(got.layers[1].sigma_a, expected.layers[1].sigma_a);
    EXPECT_EQ(got.layers[0].sigma_a, expected.layers[0].sigma_a);
    expect_same_stack(got, expected);
  }
  // More melanin: darker in every channel; more blood: less green than red.
  const LayerStack light = applied(t, {"layers[0].chromophores.melanin"}, {Spectrum(0.01)});
  const LayerStack dark = applied(t, {"layers[0].chromophores.melanin"}, {Spectrum(0.1)});
  for (int c = 0; c < kChannels; ++c) EXPECT_LT(light.layers[0].sigma_a[c], dark.layers[0].sigma_a[c]);
}

// A volume fraction's range ends where the others (but the baseline) fill the layer; values beyond
// it are clamped there, a share to [0, 1]; paths that name no chromophore say why.
TEST(StackParameters, ChromophoreRangesAndErrors) {
  const std::string text = read_text(std::string(LAMINA_SOURCE_DIR) + "/scenes/spectral/skin_spectral.json");
  const StackTemplate t = parse_stack_template_json(text, "skin_spectral.json");
  const StackParameter melanin = parse_stack_parameter(t, "layers[0].chromophores.melanin");
  EXPECT_FALSE(melanin.spectral());
  EXPECT_EQ(melanin.max_value(), 1.0);
  EXPECT_EQ(melanin.template_value(t), Spectrum(0.03));
  const StackParameter blood = parse_stack_parameter(t, "layers[1].chromophores.blood");
  EXPECT_DOUBLE_EQ(blood.max_value(), 0.4);  // water 0.6 stays
  EXPECT_EQ(parse_stack_parameter(t, "layers[1].chromophores.carotene").max_value(),
            std::numeric_limits<double>::infinity());
  expect_same_stack(applied(t, {"layers[1].chromophores.blood"}, {Spectrum(0.9)}),
                    applied(t, {"layers[1].chromophores.blood"}, {Spectrum(blood.max_value())}));
  expect_same_stack(applied(t, {"layers[1].chromophores.oxygenation"}, {Spectrum(-3.0)}),
                    applied(t, {"layers[1].chromophores.oxygenation"}, {Spectrum(0.0)}));
  auto error = [&](const std::string& path) {
    try {
      parse_stack_parameter(t, path);
    } catch (const StackParameterError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("layers[0].chromophores.melanine"),
            "layers[0].chromophores.melanine: unknown chromophore key 'melanine' (a texture can drive melanin, "
            "eumelanin, blood, oxygenation, water, fat, carotene, baseline)");
  EXPECT_EQ(error("layers[0].sigma_a"),
            "layers[0].sigma_a: layers[0] is given by chromophores: bind layers[0].chromophores.KEY");
  const StackTemplate rgb = load_stack_template(preset("skin.json"));
  EXPECT_EQ(parse_stack_parameter(t, "layers[1].chromophores.water").max_value(), 1.0 - 0.02);
  try {
    parse_stack_parameter(rgb, "layers[0].chromophores.melanin");
    FAIL() << "expected an error";
  } catch (const StackParameterError& e) {
    EXPECT_EQ(std::string(e.what()), "layers[0].chromophores.melanin: layers[0] is not given by chromophores");
  }
  std::vector<StackParameter> two = {parse_stack_parameter(t, "layers[1].chromophores.blood"),
                                     parse_stack_parameter(t, "layers[1].chromophores.water")};
  EXPECT_THROW(check_parameter_set(two), StackParameterError);
  two[1] = parse_stack_parameter(t, "layers[1].chromophores.oxygenation");
  EXPECT_NO_THROW(check_parameter_set(two));
}

// A leaf layer's contents (layers[i].leaf.KEY): every key the file reader accepts can be bound,
// and binding one sets that member of that layer alone (bound_leaf), clamped to the key's range;
// the RGB placeholders of the stack stay the file's (the spectral mode reads the contents per
// wavelength). Paths that name no leaf key, or coefficients a leaf layer computes, say why.
TEST(StackParameters, LeafKeysSetThatContentOfThatLayer) {
  const std::string path = std::string(LAMINA_SOURCE_DIR) + "/scenes/spectral/leaf_layered.json";
  const StackTemplate t = load_spectral_stack_template(path);
  ASSERT_EQ(t.layers.size(), 3u);
  ASSERT_TRUE(t.layers[1].leaf && t.layers[2].leaf);
  EXPECT_FALSE(t.layers[0].leaf->contents.chlorophyll > 0.0);
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < leaf_keys().size(); ++k) {
    const LeafKey& key = leaf_keys()[k];
    SCOPED_TRACE(key.name);
    const StackParameter p = parse_stack_parameter(t, std::string("layers[1].leaf.") + key.name);
    EXPECT_EQ(p.kind, StackParameter::Kind::kLeaf);
    EXPECT_EQ(p.layer, 1);
    EXPECT_FALSE(p.spectral());
    EXPECT_EQ(p.template_value(t), Spectrum(key.of(*t.layers[1].leaf)));
    // A value inside the range is set as given; the other members and the other layers stay.
    const double v = key.name == std::string("g") ? 0.5 : key.name == std::string("scattering_power") ? -1.5 : 3.25;
    const std::vector<StackParameter> ps = {p};
    const Spectrum values[] = {Spectrum(v)};
    const LeafChromophores got = bound_leaf(t, ps, values, 1);
    for (const LeafKey& other : leaf_keys())
      EXPECT_EQ(other.of(got), &other == &key ? v : other.of(*t.layers[1].leaf)) << other.name;
    for (const LeafKey& other : leaf_keys()) EXPECT_EQ(other.of(bound_leaf(t, ps, values, 2)), other.of(*t.layers[2].leaf));
    LayerStack out;
    apply_parameters(t, ps, values, &out);
    expect_same_stack(out, t.stack);
  }
  // Ranges: contents and plates >= 0, scattering_power [-4, 4], |g| < 1; clamped there.
  EXPECT_EQ(parse_stack_parameter(t, "layers[2].leaf.chlorophyll").max_value(), inf);
  EXPECT_EQ(parse_stack_parameter(t, "layers[2].leaf.chlorophyll").min_value(), 0.0);
  EXPECT_EQ(parse_stack_parameter(t, "layers[2].leaf.scattering_power").min_value(), -4.0);
  EXPECT_LT(parse_stack_parameter(t, "layers[2].leaf.g").max_value(), 1.0);
  const std::vector<StackParameter> ps = {parse_stack_parameter(t, "layers[2].leaf.chlorophyll"),
                                          parse_stack_parameter(t, "layers[2].leaf.scattering_power"),
                                          parse_stack_parameter(t, "layers[2].leaf.g")};
  const Spectrum values[] = {Spectrum(-3.0), Spectrum(9.0), Spectrum(1.0)};
  const LeafChromophores clamped = bound_leaf(t, ps, values, 2);
  EXPECT_EQ(clamped.contents.chlorophyll, 0.0);
  EXPECT_EQ(clamped.scattering_power, 4.0);
  EXPECT_EQ(clamped.g, ps[2].max_value());
  EXPECT_NO_THROW(check_parameter_set(ps));
  auto error = [&](const StackTemplate& st, const std::string& p) {
    try {
      parse_stack_parameter(st, p);
    } catch (const StackParameterError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error(t, "layers[1].leaf.chlorophyl"),
            "layers[1].leaf.chlorophyl: unknown leaf key 'chlorophyl' (a texture can drive chlorophyll, carotenoids, "
            "anthocyanins, brown, water, dry_matter, plates, scattering_power, g)");
  EXPECT_EQ(error(t, "layers[1].sigma_a"), "layers[1].sigma_a: layers[1] is given by leaf contents: bind layers[1].leaf.KEY");
  EXPECT_EQ(error(t, "layers[1].ior"), "layers[1].ior: layers[1] is given by leaf contents: bind layers[1].leaf.KEY");
  EXPECT_EQ(error(load_stack_template(preset("skin.json")), "layers[0].leaf.chlorophyll"),
            "layers[0].leaf.chlorophyll: layers[0] is not given by leaf contents");
  EXPECT_EQ(error(t, "layers[1].thickness"), "");  // contents are per leaf area: R and T do not depend on it
  std::vector<StackParameter> twice = {parse_stack_parameter(t, "layers[1].leaf.water"), parse_stack_parameter(t, "layers[1].leaf.water")};
  EXPECT_THROW(check_parameter_set(twice), StackParameterError);
}

// The file reader and the bindings read one list of leaf keys (leaf_keys()): a "leaf" object
// holding every key, each with its own value, sets the members leaf_keys() names; a key beyond it
// is refused, and the message lists the same keys.
TEST(StackParameters, TheReaderAcceptsExactlyTheLeafKeys) {
  nlohmann::json leaf = nlohmann::json::object();
  double v = 0.01;
  for (const LeafKey& k : leaf_keys()) leaf[k.name] = (v += 0.01);
  const nlohmann::json file = {{"lamina_material", 1},
                               {"layers", {{{"thickness", 0.1}, {"leaf", leaf}}}}};
  const SpectralStack s = parse_spectral_stack_json(file.dump(), "leaf.json");
  ASSERT_TRUE(s.leaves[0]);
  for (const LeafKey& k : leaf_keys()) EXPECT_EQ(k.of(*s.leaves[0]), leaf[k.name].get<double>()) << k.name;
  nlohmann::json bad = file;
  bad["layers"][0]["leaf"]["chlorophyl"] = 1.0;
  try {
    parse_spectral_stack_json(bad.dump(), "leaf.json");
    FAIL() << "expected an error";
  } catch (const StackFileError& e) {
    EXPECT_EQ(std::string(e.what()), "leaf.json: layers[0].leaf.chlorophyl: unknown key (allowed here: chlorophyll, "
                                     "carotenoids, anthocyanins, brown, water, dry_matter, plates, scattering_power, g)");
  }
}

TEST(StackParameters, SplitStackPathGivesKeysAndIndices) {
  const std::vector<StackPathStep> steps = split_stack_path("layers[1].components[0].fraction");
  ASSERT_EQ(steps.size(), 5u);
  EXPECT_EQ(steps[0].key, "layers");
  EXPECT_EQ(steps[1].key, "");
  EXPECT_EQ(steps[1].index, 1u);
  EXPECT_EQ(steps[3].index, 0u);
  EXPECT_EQ(steps[4].key, "fraction");
  EXPECT_EQ(split_stack_path("below.lambert").size(), 2u);
  for (const char* bad : {"", "layers[1..x", "layers[", "layers[]", "layers[1234567]", "layers[-1]", "a.", ".a", "a..b"})
    EXPECT_THROW(split_stack_path(bad), StackParameterError) << bad;
  nlohmann::json stack = nlohmann::json::parse(R"({"layers": [{"thickness": 0.1}]})");
  *find_stack_value(stack, split_stack_path("layers[0].thickness"), "layers[0].thickness") = 0.2;
  EXPECT_EQ(stack["layers"][0]["thickness"], 0.2);
  try {
    find_stack_value(stack, split_stack_path("layers[7].thickness"), "layers[7].thickness");
    ADD_FAILURE() << "no error";
  } catch (const StackParameterError& e) {
    EXPECT_STREQ(e.what(), "'layers[7].thickness': 'layers' has 1 entries, no [7]");
  }
}

}  // namespace
}  // namespace lamina
