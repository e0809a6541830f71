// The spectral albedo fit (materials/fit/spectral_albedo): the colour of a chromophore skin's
// diffuse albedo spectrum against the same sum done here; colours the forward model gives at
// known (melanin, blood) matched back within a tolerance derived from the table's own error at
// that point; a colour beyond the model's gamut matched to its nearest colour, on the bound.
#include "materials/fit/spectral_albedo.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "materials/spectral/chromophores.h"
#include "materials/tables/albedo.h"

namespace lamina {
namespace {

const std::string kMaterial = std::string(LAMINA_SOURCE_DIR) + "/scenes/head_skin/skin_chromophores_conserving.json";
const std::vector<FitParameterSpec> kAxes = {{"layers[1].chromophores.melanin", 0.0, 0.2},
                                             {"layers[2].chromophores.blood", 0.0, 0.1}};
const AddingDoublingSettings kSettings{6};

// A small table (9 x 9 nodes at 6 points) keeps the suite fast; the tolerances below follow from
// its error, so a finer table only tightens them.
const SpectralAlbedoTable& small_table() {
  static const SpectralAlbedoTable t =
      build_spectral_albedo_table(load_chromophore_material(kMaterial), kAxes, 9, kSettings, AlbedoKind::kDiffuse);
  return t;
}

// The colour is the film's projection of the per-wavelength albedo: the same sum written out with
// the melanin bound as a map binds it (the baseline gives what melanin takes).
TEST(SpectralAlbedo, ColourIsTheProjectionOfTheAlbedoSpectrumWithTheMapsBindingSemantics) {
  const ChromophoreMaterial m = load_chromophore_material(kMaterial);
  const std::vector<StackParameter> ps = check_spectral_albedo_axes(m, kAxes);
  const double v[2] = {0.08, 0.03};
  const Spectrum colour = spectral_albedo_colour(m, ps, v, AlbedoKind::kDiffuse, kSettings);
  SpectralStack s = m.spectral;
  const double melanin0 = s.chromophores[1]->melanin, blood0 = s.chromophores[2]->blood;
  s.chromophores[1]->melanin = 0.08;
  s.chromophores[1]->baseline -= 0.08 - melanin0;
  s.chromophores[2]->blood = 0.03;
  s.chromophores[2]->baseline -= 0.03 - blood0;
  AddingDoublingSettings one = kSettings;
  one.only_channel = 0;
  const Spectrum expected = rec709_channel_mean(
      [&](double nm) { return diffuse_bihemispherical_albedo_adding_doubling(stack_at_wavelength(s, nm), one)[0]; });
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(colour[c], expected[c], 1e-12) << c;
  // Skin: red above green above blue, and more melanin darker in every channel.
  EXPECT_GT(colour[0], colour[1]);
  EXPECT_GT(colour[1], colour[2]);
  const double darker[2] = {0.16, 0.03};
  const Spectrum d = spectral_albedo_colour(m, ps, darker, AlbedoKind::kDiffuse, kSettings);
  for (int c = 0; c < kChannels; ++c) EXPECT_LT(d[c], colour[c]) << c;
}

// A colour the forward model gives at known parameters u0 (solved directly, not from the table) is
// matched to u*. The table differs from the model at u0 by e (in L*a*b*); the match minimises the
// distance to the target over the table, so (1) its Delta E is at most |e|, and (2) the table's
// colours at u* and u0 are at most 2|e| apart, so to first order |u* - u0| <= 2|e| / s_min, s_min
// the smaller singular value of the table's Jacobian d Lab / du at u0. The test allows 1.5 times
// that (the second order over a distance of a few thousandths of the range).
TEST(SpectralAlbedo, ForwardModelColoursAreMatchedBackWithinTheTablesDerivedError) {
  const ChromophoreMaterial m = load_chromophore_material(kMaterial);
  const std::vector<StackParameter> ps = check_spectral_albedo_axes(m, kAxes);
  const SpectralAlbedoTable& t = small_table();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uniform(0.05, 0.95);
  for (int k = 0; k < 8; ++k) {
    const double u0[2] = {uniform(rng), uniform(rng)};
    const double v[2] = {0.2 * u0[0], 0.1 * u0[1]};
    const Spectrum target = spectral_albedo_colour(m, ps, v, AlbedoKind::kDiffuse, kSettings);
    const double e = delta_e76(linear_rgb_to_lab(t.at(u0[0], u0[1])), linear_rgb_to_lab(target));
    const AlbedoMatch match = match_spectral_albedo(t, target);
    EXPECT_LE(match.delta_e, e + 1e-9) << k;
    // s_min from the 2 x 2 normal matrix of central differences.
    constexpr double h = 1e-5;
    Spectrum J[2];
    for (int a = 0; a < 2; ++a) {
      double lo[2] = {u0[0], u0[1]}, hi[2] = {u0[0], u0[1]};
      lo[a] -= h, hi[a] += h;
      J[a] = (1.0 / (2 * h)) * (linear_rgb_to_lab(t.at(hi[0], hi[1])) - linear_rgb_to_lab(t.at(lo[0], lo[1])));
    }
    auto dot = [](const Spectrum& x, const Spectrum& y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
    const double a = dot(J[0], J[0]), b = dot(J[0], J[1]), c = dot(J[1], J[1]);
    const double s_min = std::sqrt(0.5 * (a + c - std::sqrt((a - c) * (a - c) + 4 * b * b)));
    const double tolerance = 1.5 * 2.0 * e / s_min + 1e-6;
    const double du = std::hypot((match.value[0] - v[0]) / 0.2, (match.value[1] - v[1]) / 0.1);
    if (std::getenv("LAMINA_TEST_VERBOSE"))
      std::printf("melanin %.4f blood %.4f: table error Delta E %.4f, match Delta E %.4f, |du| %.2e <= %.2e\n", v[0], v[1], e,
                  match.delta_e, du, tolerance);
    EXPECT_LE(du, tolerance) << k << ": melanin " << v[0] << " -> " << match.value[0] << ", blood " << v[1] << " -> "
                             << match.value[1] << ", table error Delta E " << e << ", s_min " << s_min;
    // The table is not vacuous: its error is small against the spread of skin colours.
    EXPECT_LT(e, 1.0) << k;
  }
}

// A colour lighter than no melanin gives (the model's colour at melanin 0 made 15 % lighter) is out
// of the model's gamut: the match holds melanin on its bound 0 and returns the nearest colour the
// table has, which a dense scan over the whole table confirms.
TEST(SpectralAlbedo, AColourOutOfGamutGetsTheNearestColourOnTheBound) {
  const SpectralAlbedoTable& t = small_table();
  const Spectrum target = 1.15 * t.at(0.0, 0.4);
  const Spectrum lab = linear_rgb_to_lab(target);
  const AlbedoMatch match = match_spectral_albedo(t, target);
  EXPECT_EQ(match.value[0], 0.0);
  EXPECT_GT(match.delta_e, 1.0);
  double nearest = 1e300;
  for (int i = 0; i <= 400; ++i)
    for (int j = 0; j <= 400; ++j) nearest = std::min(nearest, delta_e76(linear_rgb_to_lab(t.at(i / 400.0, j / 400.0)), lab));
  EXPECT_LE(match.delta_e, nearest + 1e-6);
  EXPECT_NEAR(match.delta_e, delta_e76(linear_rgb_to_lab(match.albedo), lab), 1e-9);
}

// The interpolant passes through the nodes and is continuous across cells.
TEST(SpectralAlbedo, TableInterpolatesItsNodes) {
  const SpectralAlbedoTable& t = small_table();
  for (int i = 0; i < t.nodes; i += 3)
    for (int j = 0; j < t.nodes; j += 4) {
      const Spectrum a = t.at(i / (t.nodes - 1.0), j / (t.nodes - 1.0));
      for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(a[c], t.colour[i * t.nodes + j][c], 1e-12);
    }
  const double edge = 3.0 / (t.nodes - 1.0);
  const Spectrum below = t.at(edge - 1e-12, 0.3), above = t.at(edge + 1e-12, 0.3);
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(below[c], above[c], 1e-9);
}

TEST(SpectralAlbedo, AxesMustBeChromophoresWithinTheirRange) {
  const ChromophoreMaterial m = load_chromophore_material(kMaterial);
  EXPECT_THROW(check_spectral_albedo_axes(m, {kAxes[0]}), FitError);
  EXPECT_THROW(check_spectral_albedo_axes(m, {kAxes[0], {"layers[1].thickness", 0.05, 0.2}}), FitError);
  EXPECT_THROW(check_spectral_albedo_axes(m, {kAxes[0], {"layers[2].chromophores.blood", 0.0, 1.5}}), FitError);
  EXPECT_THROW(check_spectral_albedo_axes(m, {kAxes[0], {"layers[0].chromophores.blood", 0.0, 0.1}}), FitError);
  EXPECT_THROW(check_spectral_albedo_axes(m, {kAxes[0], kAxes[0]}), FitError);
  EXPECT_TRUE(chromophore_axes(kAxes));
  EXPECT_FALSE(chromophore_axes({kAxes[0], {"layers[1].components[0].fraction", 0.0, 0.3}}));
}

}  // namespace
}  // namespace lamina
