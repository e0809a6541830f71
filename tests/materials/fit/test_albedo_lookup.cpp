// The albedo lookup (materials/fit/albedo_lookup): L*a*b* against published values, and the round
// trip colour -> parameters on the skin preset: the albedo of random (melanin, blood) fractions,
// solved directly (not from the table), is matched back to fractions near the truth.
#include "materials/fit/albedo_lookup.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "materials/tables/albedo.h"
#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

// Bruce Lindbloom's calculator (sRGB, D65, reference white Y = 100), which implements CIE 15:
// sRGB (1, 0, 0) is L*a*b* (53.2408, 80.0925, 67.2032); (0, 0, 1): (32.2970, 79.1875, -107.8602).
// IEC 61966-2-1's 4-digit matrix moves them by up to ~0.05.
TEST(AlbedoLookup, LabMatchesPublishedValues) {
  const Spectrum w = linear_rgb_to_lab(Spectrum(1.0));
  EXPECT_NEAR(w[0], 100.0, 1e-9);
  EXPECT_NEAR(w[1], 0.0, 1e-9);
  EXPECT_NEAR(w[2], 0.0, 1e-9);
  const Spectrum r = linear_rgb_to_lab({1.0, 0.0, 0.0});
  EXPECT_NEAR(r[0], 53.2408, 0.05);
  EXPECT_NEAR(r[1], 80.0925, 0.1);
  EXPECT_NEAR(r[2], 67.2032, 0.1);
  const Spectrum b = linear_rgb_to_lab({0.0, 0.0, 1.0});
  EXPECT_NEAR(b[0], 32.2970, 0.05);
  EXPECT_NEAR(b[1], 79.1875, 0.1);
  EXPECT_NEAR(b[2], -107.8602, 0.1);
}

// The match is the minimum of Delta E over the table's bilinear surface, so it is at least as close
// as the table at the true fractions; its error is the table's interpolation error, which falls
// as the square of the spacing (bilinear interpolation): halving the spacing must at least halve
// the worst parameter error.
TEST(AlbedoLookup, SkinColoursMapBackToTheirFractions) {
  const StackTemplate t = load_stack_template(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  const std::vector<FitParameterSpec> axes = {{"layers[0].components[0].fraction", 0.0, 0.3},
                                              {"layers[1].components[0].fraction", 0.0, 0.2}};
  const AddingDoublingSettings settings{8};
  std::vector<StackParameter> ps = {parse_stack_parameter(t, axes[0].path), parse_stack_parameter(t, axes[1].path)};
  double previous = 0.0;
  for (int nodes : {9, 17, 33}) {
    const AlbedoLookup table = build_albedo_lookup(t, axes, nodes, settings, AlbedoKind::kTotal);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.05, 0.95);
    double worst_e = 0.0, worst = 0.0;
    for (int k = 0; k < 20; ++k) {
      const double u0 = u(rng), u1 = u(rng);
      const Spectrum v[2] = {Spectrum(0.3 * u0), Spectrum(0.2 * u1)};
      LayerStack s;
      apply_parameters(t, ps, v, &s);
      const Spectrum albedo = adding_doubling_totals(s, 1.0, settings).R_hemispherical;
      const AlbedoMatch m = match_albedo(table, albedo);
      EXPECT_LE(m.delta_e, delta_e76(linear_rgb_to_lab(table.at(u0, u1)), linear_rgb_to_lab(albedo)) + 1e-6);
      worst_e = std::max(worst_e, m.delta_e);
      worst = std::max({worst, std::abs(m.value[0] / 0.3 - u0), std::abs(m.value[1] / 0.2 - u1)});
    }
    std::printf("%d nodes: worst Delta E %.4f, worst parameter error %.5f of the range\n", nodes, worst_e, worst);
    if (previous > 0.0) {
      EXPECT_LT(worst, 0.5 * previous) << nodes << " nodes";
    }
    previous = worst;
  }
}

// The image form is match_albedo per texel, whatever the blocks and threads: every field equal.
TEST(AlbedoLookup, MapMatchesEachTexelAsMatchAlbedoDoes) {
  const StackTemplate t = load_stack_template(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  const AlbedoLookup table = build_albedo_lookup(
      t, {{"layers[0].components[0].fraction", 0.0, 0.3}, {"layers[1].components[0].fraction", 0.0, 0.2}}, 9,
      AddingDoublingSettings{4}, AlbedoKind::kDiffuse);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const std::size_t texels = 5000;  // more than one block
  std::vector<float> rgb(3 * texels);
  for (float& v : rgb) v = u(rng);
  std::size_t reported = 0;
  const AlbedoMapMatch map = match_albedo_map(table, rgb.data(), texels, [&](std::size_t n) { reported += n; });
  EXPECT_EQ(reported, texels);
  for (std::size_t i = 0; i < texels; i += 97) {
    const AlbedoMatch m = match_albedo(table, Spectrum(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]));
    EXPECT_EQ(map.value[0][i], m.value[0]);
    EXPECT_EQ(map.value[1][i], m.value[1]);
    EXPECT_EQ(map.delta_e[i], m.delta_e);
    EXPECT_EQ(map.albedo[i], m.albedo);
  }
}

// The diffuse table holds the renderer's Lambert albedo (R_h - R_hs) at each node: below the total
// R_hemispherical by the specular reflection of the top, the same in every channel and at every
// node (the layers below match its index 1.4): Fresnel's reflectance of n 1.4 for uniform diffuse
// light, 2 int F(mu) mu dmu = 0.076812 (numerical integration of the unpolarised Fresnel factor).
TEST(AlbedoLookup, DiffuseTableHoldsTheLambertAlbedo) {
  const StackTemplate t = load_stack_template(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  const std::vector<FitParameterSpec> axes = {{"layers[0].components[0].fraction", 0.0, 0.3},
                                              {"layers[1].components[0].fraction", 0.0, 0.2}};
  const AddingDoublingSettings settings{8};
  const AlbedoLookup diffuse = build_albedo_lookup(t, axes, 3, settings, AlbedoKind::kDiffuse);
  const AlbedoLookup total = build_albedo_lookup(t, axes, 3, settings, AlbedoKind::kTotal);
  std::vector<StackParameter> ps = {parse_stack_parameter(t, axes[0].path), parse_stack_parameter(t, axes[1].path)};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const Spectrum v[2] = {Spectrum(0.15 * i), Spectrum(0.1 * j)};
      LayerStack s;
      apply_parameters(t, ps, v, &s);
      const Spectrum expected = diffuse_bihemispherical_albedo_adding_doubling(s, settings);
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(diffuse.albedo[i * 3 + j][c], expected[c]);
        EXPECT_NEAR(total.albedo[i * 3 + j][c] - diffuse.albedo[i * 3 + j][c], 0.076812, 1e-5) << i << " " << j << " " << c;
      }
    }
}

// The albedo-texture fit on a rough energy-conserving material (the oily skin preset: sebum,
// epidermis, dermis under alpha 0.4): a known map of (melanin, blood) fractions, 20 texels at
// random in 5-95% of the ranges, its colours the diffuse albedo solved directly at those
// fractions, is matched back per texel within the lookup's stated errors (albedo_lookup.h: 2.2%
// of each range at 17 nodes on the smooth skin preset, 1.3% at 33, the CLI's default, on the CLI
// round trip's grid), and the error falls at least by half from 17 to 33 nodes (bilinear
// interpolation: with the square of the spacing).
TEST(AlbedoLookup, RoughEnergyConservingMapComesBack) {
  const StackTemplate t = load_stack_template(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin_oily.json");
  ASSERT_TRUE(t.stack.rough_top());
  ASSERT_TRUE(t.stack.energy_conserving_rough());
  const std::vector<FitParameterSpec> axes = {{"layers[1].components[0].fraction", 0.0, 0.3},
                                              {"layers[2].components[0].fraction", 0.0, 0.2}};
  const AddingDoublingSettings settings{8};
  std::vector<StackParameter> ps = {parse_stack_parameter(t, axes[0].path), parse_stack_parameter(t, axes[1].path)};
  constexpr int kTexels = 20;
  double truth[2][kTexels];
  std::vector<float> rgb(3 * kTexels);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.05, 0.95);
  for (int i = 0; i < kTexels; ++i) {
    truth[0][i] = u(rng);
    truth[1][i] = u(rng);
    const Spectrum v[2] = {Spectrum(0.3 * truth[0][i]), Spectrum(0.2 * truth[1][i])};
    LayerStack s;
    apply_parameters(t, ps, v, &s);
    const Spectrum albedo = diffuse_bihemispherical_albedo_adding_doubling(s, settings);
    for (int c = 0; c < 3; ++c) rgb[3 * i + c] = static_cast<float>(albedo[c]);
  }
  double previous = 0.0;
  for (int nodes : {17, 33}) {
    const AlbedoLookup table = build_albedo_lookup(t, axes, nodes, settings, AlbedoKind::kDiffuse);
    const AlbedoMapMatch map = match_albedo_map(table, rgb.data(), kTexels);
    double worst = 0.0, worst_e = 0.0;
    for (int i = 0; i < kTexels; ++i) {
      worst = std::max({worst, std::abs(map.value[0][i] / 0.3 - truth[0][i]), std::abs(map.value[1][i] / 0.2 - truth[1][i])});
      worst_e = std::max(worst_e, map.delta_e[i]);
    }
    std::printf("%d nodes: worst Delta E %.4f, worst parameter error %.5f of the range\n", nodes, worst_e, worst);
    EXPECT_LT(worst, nodes == 17 ? 0.022 : 0.013) << nodes << " nodes";
    if (previous > 0.0) {
      EXPECT_LT(worst, 0.5 * previous) << nodes << " nodes";
    }
    previous = worst;
  }
}

// A rough top's roughness, or an index on a rough stack, would change the interfaces' projection
// at every node: not an axis (stack_fit.h, rough_projection_refusal).
TEST(AlbedoLookup, RoughProjectionAxesAreOneLineErrors) {
  const StackTemplate t = load_stack_template(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin_oily.json");
  auto error_of = [&](const std::vector<FitParameterSpec>& axes) {
    try {
      check_albedo_axes(t, axes);
    } catch (const FitError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error_of({{"roughness", 0.1, 0.5}, {"layers[2].components[0].fraction", 0.0, 0.2}}).find("roughness: "), 0u);
  EXPECT_EQ(error_of({{"layers[1].ior", 1.3, 1.5}, {"layers[2].components[0].fraction", 0.0, 0.2}}).find("layers[1].ior: "), 0u);
  EXPECT_EQ(error_of({{"layers[1].components[0].fraction", 0.0, 0.3}, {"layers[2].components[0].fraction", 0.0, 0.2}}), "");
}

TEST(AlbedoLookup, DeltaEStatistics) {
  // 1..20: mean 10.5, median 10.5 (between the 10th and 11th), 95th percentile the 19th value
  // (nearest rank, ceil(0.95 * 20) = 19), max 20; above 15: 5.
  std::vector<double> e;
  for (int i = 20; i >= 1; --i) e.push_back(i);
  const DeltaEStatistics s = delta_e_statistics(e, 15.0);
  EXPECT_DOUBLE_EQ(s.mean, 10.5);
  EXPECT_DOUBLE_EQ(s.median, 10.5);
  EXPECT_DOUBLE_EQ(s.p95, 19.0);
  EXPECT_DOUBLE_EQ(s.max, 20.0);
  EXPECT_EQ(s.above, 5u);
  const DeltaEStatistics odd = delta_e_statistics({3.0, 1.0, 2.0}, 5.0);
  EXPECT_DOUBLE_EQ(odd.median, 2.0);
  EXPECT_DOUBLE_EQ(odd.p95, 3.0);
  EXPECT_EQ(odd.above, 0u);
  EXPECT_EQ(delta_e_statistics({}, 1.0).max, 0.0);
}

TEST(AlbedoLookup, BadAxesAreOneLineErrors) {
  const StackTemplate t = load_stack_template(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  EXPECT_THROW(build_albedo_lookup(t, {{"layers[0].sigma_a", 0.0, 1.0}, {"layers[1].thickness", 0.1, 1.0}}, 4, {}, AlbedoKind::kDiffuse), FitError);
  EXPECT_THROW(build_albedo_lookup(t, {{"layers[0].thickness", 1.0, 0.1}, {"layers[1].thickness", 0.1, 1.0}}, 4, {}, AlbedoKind::kDiffuse), FitError);
  EXPECT_THROW(build_albedo_lookup(t, {{"layers[0].thickness", 0.1, 1.0}}, 4, {}, AlbedoKind::kDiffuse), FitError);
}

}  // namespace
}  // namespace lamina
