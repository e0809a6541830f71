// materials/spectral/chromophores and the spectral stack: each chromophore's spectrum against the
// published numbers it comes from, the layer's sums, the material file's chromophore layers
// (values and one-line errors), and adding-doubling per wavelength (materials/adding_doubling/
// spectral_totals) against the grey solver it is made of; the spectral fit (materials/fit/
// spectral_fit) recovering a synthetic spectrum's parameters.
#include "materials/spectral/chromophores.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>
#include <string>

#include <gtest/gtest.h>

#include "materials/adding_doubling/spectral_totals.h"
#include "materials/fit/spectral_fit.h"
#include "materials/stack/stack_file.h"
#include "materials/spectral/colour.h"

namespace lamina {
namespace {

// Donner and Jensen's power laws: 6.6e10 nm^-3.33 and 2.9e14 nm^-4.75 per mm; their slopes.
TEST(Chromophores, MelaninPowerLaws) {
  EXPECT_NEAR(eumelanin_absorption(500.0), 67.92, 0.01);
  EXPECT_NEAR(pheomelanin_absorption(500.0), 43.88, 0.01);
  EXPECT_NEAR(eumelanin_absorption(400.0) / eumelanin_absorption(800.0), std::pow(2.0, 3.33), 1e-9);
  EXPECT_NEAR(pheomelanin_absorption(400.0) / pheomelanin_absorption(800.0), std::pow(2.0, 4.75), 1e-9);
}

// Prahl's table at its nodes (molar extinction, 1/cm per mol/L) through mu_a = ln(10) eps 150 /
// 64500 (1/cm), and the facts pulse oximetry rests on: deoxygenated blood absorbs about ten times
// more at 660 nm, oxygenated more at 940 nm, the two alike near 800 nm.
TEST(Chromophores, BloodFromPrahlsTable) {
  const double per_mm = std::log(10.0) * 150.0 / 64500.0 / 10.0;
  EXPECT_NEAR(oxy_blood_absorption(550.0), 43016.0 * per_mm, 1e-9);
  EXPECT_NEAR(deoxy_blood_absorption(550.0), 53412.0 * per_mm, 1e-9);
  EXPECT_NEAR(deoxy_blood_absorption(660.0), 3226.56 * per_mm, 1e-9);
  EXPECT_NEAR(oxy_blood_absorption(661.0), 0.5 * (319.6 + oxy_blood_absorption(662.0) / per_mm) * per_mm, 1e-9);
  EXPECT_GT(deoxy_blood_absorption(660.0) / oxy_blood_absorption(660.0), 9.0);
  EXPECT_GT(oxy_blood_absorption(940.0), 1.5 * deoxy_blood_absorption(940.0));
  EXPECT_NEAR(oxy_blood_absorption(800.0) / deoxy_blood_absorption(800.0), 1.0, 0.1);
  // Beyond the table (250-1000 nm) the end values hold.
  EXPECT_EQ(oxy_blood_absorption(1200.0), oxy_blood_absorption(1000.0));
}

// Water's near-infrared bands (PROSPECT-D's Kw: 0.48 1/cm at 970 nm, 30.5 1/cm at 1450 nm, as
// Hale and Querry 1973 and Kou et al. 1993 measure), fat and the skin baseline at their sources'
// values, carotene through PROSPECT-D's carotenoids.
TEST(Chromophores, WaterFatBaselineCarotene) {
  EXPECT_NEAR(water_absorption(970.0), 0.048, 1e-6);
  EXPECT_NEAR(water_absorption(1450.0), 3.054, 1e-6);
  EXPECT_LT(water_absorption(450.0), 1e-4);
  EXPECT_NEAR(fat_absorption(450.0), 0.006375, 1e-9);
  EXPECT_EQ(fat_absorption(400.0), fat_absorption(450.0));  // held below the table
  EXPECT_NEAR(skin_baseline_absorption(450.0), 0.1219, 1e-4);  // Jacques: 1.219 1/cm at 450 nm
  EXPECT_NEAR(carotene_absorption_per_concentration(480.0), 0.0133271, 1e-7);
}

TEST(Chromophores, ScatteringPowerLaw) {
  ScatteringPowerLaw rayleigh{2.0, 1.0, 0.5};
  EXPECT_DOUBLE_EQ(rayleigh.reduced(500.0), 2.0);
  EXPECT_NEAR(rayleigh.reduced(1000.0), 2.0 / 16.0, 1e-15);
  ScatteringPowerLaw skin{4.6, 0.409, 0.702};  // Jacques 2013, Table 2, skin
  EXPECT_NEAR(skin.reduced(1000.0), 4.6 * (0.409 / 16.0 + 0.591 * std::pow(2.0, -0.702)), 1e-12);
  SkinChromophores c;
  c.scattering = skin;
  c.g = 0.75;
  EXPECT_NEAR(c.scattering_coefficient(600.0), skin.reduced(600.0) * 4.0, 1e-12);
}

// The layer's absorption is the sum of its parts, each weighted by its fraction.
TEST(Chromophores, LayerAbsorptionIsTheWeightedSum) {
  SkinChromophores c;
  c.melanin = 0.1, c.eumelanin = 0.6, c.blood = 0.05, c.oxygenation = 0.8, c.water = 0.3, c.fat = 0.1;
  c.carotene = 2.0, c.baseline = 0.4;
  for (double nm : {420.0, 555.0, 700.0, 990.0}) {
    const double expected =
        0.1 * (0.6 * eumelanin_absorption(nm) + 0.4 * pheomelanin_absorption(nm)) +
        0.05 * (0.8 * oxy_blood_absorption(nm) + 0.2 * deoxy_blood_absorption(nm)) + 0.3 * water_absorption(nm) +
        0.1 * fat_absorption(nm) + 2.0 * carotene_absorption_per_concentration(nm) + 0.4 * skin_baseline_absorption(nm);
    EXPECT_NEAR(c.absorption(nm), expected, 1e-12 * expected) << nm;
  }
}

const char* kSpectralSkin = R"({"lamina_material": 1, "layers": [
  {"name": "epidermis", "ior": 1.4, "thickness": 0.1,
   "chromophores": {"melanin": 0.05, "eumelanin": 0.7, "baseline": 0.95,
                    "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}},
  {"name": "dermis", "ior": 1.4, "thickness": 2.0,
   "chromophores": {"blood": 0.02, "oxygenation": 0.75, "baseline": 0.98,
                    "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}}],
  "below": {"lambert": 0.5}})";

TEST(SpectralStack, ReadsChromophoreLayers) {
  const SpectralStack s = parse_spectral_stack_json(kSpectralSkin, "skin.json");
  ASSERT_EQ(s.chromophores.size(), 2u);
  ASSERT_TRUE(s.chromophores[0] && s.chromophores[1]);
  EXPECT_EQ(s.chromophores[0]->melanin, 0.05);
  EXPECT_EQ(s.chromophores[1]->oxygenation, 0.75);
  const LayerStack at600 = stack_at_wavelength(s, 600.0);
  EXPECT_TRUE(at600.grey());
  EXPECT_DOUBLE_EQ(at600.layers[0].sigma_a[0], s.chromophores[0]->absorption(600.0));
  EXPECT_DOUBLE_EQ(at600.layers[1].sigma_s()[0], s.chromophores[1]->scattering_coefficient(600.0));
  EXPECT_DOUBLE_EQ(at600.layers[1].lobes[0].g[0], 0.8);
  EXPECT_EQ(at600.below.albedo, Spectrum(0.5));
}

std::string spectral_error(const std::string& json) {
  try {
    parse_spectral_stack_json(json, "m.json");
  } catch (const StackFileError& e) {
    return e.what();
  }
  return "";
}

// The channel weights: a reflectance's projection is its colour under D65 (against the colour
// pipeline, reflectance_to_linear_rec709, whose white point differs by 1e-4), a grey stays grey,
// and each channel's weight lies where its primary is (red beyond 570 nm, green near 540, blue
// below 480) with the negative lobe of the colour-matching functions (red at 500 nm).
TEST(ChromophoreRgb, ChannelWeightsGiveTheColour) {
  const ChannelWeights& cw = rec709_channel_weights();
  for (int c = 0; c < 3; ++c) {
    double sum = 0.0, centroid = 0.0;
    for (int i = 0; i < 85; ++i) {
      sum += cw.w[i][c];
      centroid += std::max(0.0, cw.w[i][c]) * cw.nm(i);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    double positive = 0.0;
    for (int i = 0; i < 85; ++i) positive += std::max(0.0, cw.w[i][c]);
    centroid /= positive;
    const double lo[3] = {570.0, 520.0, 430.0}, hi[3] = {640.0, 560.0, 480.0};
    EXPECT_GT(centroid, lo[c]) << c;
    EXPECT_LT(centroid, hi[c]) << c;
  }
  EXPECT_LT(cw.w[28][0], 0.0);  // 500 nm
  const Spectrum grey = rec709_channel_mean([](double) { return 0.37; });
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(grey[c], 0.37, 1e-15);
  std::vector<double> nm, r;
  for (int i = 0; i < 85; ++i) {
    nm.push_back(cw.nm(i));
    r.push_back(0.2 + 0.5 * std::exp(-std::pow((cw.nm(i) - 610.0) / 40.0, 2.0)));
  }
  const Spectrum projected = rec709_channel_mean([&](double x) { return TabulatedSpectrum(nm, r)(x); });
  const Spectrum colour = reflectance_to_linear_rec709(TabulatedSpectrum(nm, r));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(projected[c], colour[c], 2e-4) << c;
}

// absorption_rgb(): melanin, falling with the wavelength, absorbs blue most and red least, its red
// value between its values at the red channel's ends; a layer that does not scatter takes the mean.
TEST(ChromophoreRgb, MelaninAbsorbsBlueMostAndAnAbsorberTakesTheMean) {
  SkinChromophores m;
  m.melanin = 0.05;
  m.scattering = {3.0, 0.3, 0.7};
  const Spectrum mel = m.absorption_rgb();
  EXPECT_GT(mel[2], mel[1]);
  EXPECT_GT(mel[1], mel[0]);
  EXPECT_LT(mel[0], 0.05 * eumelanin_absorption(570.0));
  EXPECT_GT(mel[0], 0.05 * eumelanin_absorption(700.0));
  m.scattering = {};
  const Spectrum mean = rec709_channel_mean([&](double nm) { return m.absorption(nm); });
  EXPECT_EQ(m.absorption_rgb(), mean);
}

// What the RGB coefficients are for: the RGB mode's total reflectance of a chromophore stack is
// about the colour of its spectrum (adding-doubling per wavelength, 360-780 nm every 5 nm, under
// D65). The coefficients invert a diffusion formula per layer, so they are exact for none of the
// stacks; the bound is the approximation's measured error (largest 0.0065 on these stacks, 0.007 on the
// skin-tone presets, docs/skin_tones.md), with room: 0.012 per channel.
TEST(ChromophoreRgb, RgbModeShowsAboutTheSpectrumsColour) {
  const char* dermis = R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": "inf",
     "chromophores": {"blood": 0.02, "oxygenation": 0.75, "water": 0.6, "baseline": 0.38,
                      "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}}}]})";
  const char* dark = R"({"lamina_material": 1, "layers": [
     {"ior": 1.4, "thickness": 0.1, "chromophores": {"melanin": 0.2, "eumelanin": 0.5, "baseline": 0.8,
      "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}}},
     {"ior": 1.4, "thickness": "inf", "chromophores": {"blood": 0.01, "oxygenation": 0.5, "water": 0.6, "baseline": 0.38,
      "scattering": {"reduced_500": 5.0, "f_rayleigh": 0.409, "b_mie": 0.702}}}]})";
  const double mu = std::cos(8.0 * M_PI / 180.0);
  for (const char* json : {dermis, kSpectralSkin, dark}) {
    const SpectralTotals t = adding_doubling_spectrum(parse_spectral_stack_json(json, "s.json"),
                                                      WavelengthGrid::from_to(360.0, 780.0, 5.0), mu);
    std::vector<double> r;
    for (const AddingDoublingEstimate& e : t.estimates) r.push_back(e.totals.R_specular[0] + e.totals.R_diffuse[0]);
    const Spectrum colour = reflectance_to_linear_rec709(TabulatedSpectrum(t.nm, r));
    const AddingDoublingTotals rgb = adding_doubling_totals(parse_stack_json(json, "s.json"), mu);
    for (int c = 0; c < 3; ++c) {
      std::printf("channel %d: spectrum %.4f, RGB mode %.4f\n", c, colour[c], rgb.R_specular[c] + rgb.R_diffuse[c]);
      EXPECT_NEAR(rgb.R_specular[c] + rgb.R_diffuse[c], colour[c], 0.012) << c;
    }
  }
}

// The RGB readers (the renderer's, `lamina brdf`'s) take a chromophore layer as its RGB means; the
// spectral reader keeps its 550-nm placeholders and the chromophores.
TEST(SpectralStack, RgbReaderTakesTheChannelMeans) {
  const StackTemplate t = parse_stack_template_json(kSpectralSkin, "skin.json");
  const SpectralStack s = parse_spectral_stack_json(kSpectralSkin, "skin.json");
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(t.layers[i].chromophores);
    EXPECT_EQ(t.layers[i].chromophores->melanin, s.chromophores[i]->melanin);
    EXPECT_EQ(t.stack.layers[i].sigma_a, s.chromophores[i]->absorption_rgb());
    EXPECT_EQ(t.stack.layers[i].lobes[0].sigma_s, s.chromophores[i]->scattering_coefficient_rgb());
    EXPECT_EQ(s.stack.layers[i].sigma_a, Spectrum(s.chromophores[i]->absorption(550.0)));
  }
  EXPECT_EQ(validate_stack(t.stack), "");
}

TEST(SpectralStack, OneLineErrorsNameTheValue) {
  const std::string head = R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 1, )";
  EXPECT_EQ(spectral_error(head + R"("chromophores": {"melanin": 0.6, "baseline": 0.5}}]})"),
            "m.json: layers[0].chromophores: volume fractions melanin + blood + water + fat + baseline must not "
            "exceed 1 (sum 1.1)");
  EXPECT_EQ(spectral_error(head + R"("chromophores": {"blood": 1.5}}]})"),
            "m.json: layers[0].chromophores.blood: must lie in [0, 1] (got 1.5)");
  EXPECT_EQ(spectral_error(head + R"("chromophores": {"melanine": 0.1}}]})").rfind("m.json: layers[0].chromophores.melanine: unknown key", 0),
            0u);
  EXPECT_EQ(spectral_error(head + R"("chromophores": {"baseline": 1, "g": [0.8, 0.8, 0.8]}}]})"),
            "m.json: layers[0].chromophores.g: expected a number (one g at every wavelength), got an array");
  EXPECT_EQ(spectral_error(head + R"("chromophores": {"baseline": 1}, "sigma_a": 1}]})"),
            "m.json: layers[0]: give either chromophores, or sigma_a, sigma_s and g, or components, not two of them");
  EXPECT_EQ(spectral_error(head + R"("sigma_a": [1, 2, 3], "sigma_s": 1, "g": 0}]})"),
            "m.json: layers[0]: in a stack with chromophore layers every other layer must be grey (one number per "
            "coefficient)");
  EXPECT_EQ(spectral_error(head + R"("chromophores": {"baseline": 1}}], "below": {"lambert": [0.1, 0.2, 0.3]}})"),
            "m.json: below.lambert: in a stack with chromophore layers the substrate's albedo must be grey (one number)");
}

// Each wavelength is the grey solver on stack_at_wavelength; energy is conserved; a stack without
// chromophore layers has the same totals at every wavelength, those of the RGB solver.
TEST(SpectralTotals, AreTheGreySolverPerWavelength) {
  const SpectralStack s = parse_spectral_stack_json(kSpectralSkin, "skin.json");
  const WavelengthGrid grid = WavelengthGrid::from_to(400.0, 1000.0, 100.0);
  const double mu = std::cos(8.0 * 3.14159265358979323846 / 180.0);
  const SpectralTotals t = adding_doubling_spectrum(s, grid, mu);
  ASSERT_EQ(t.nm.size(), 7u);
  for (std::size_t i = 0; i < t.nm.size(); ++i) {
    const AddingDoublingTotals direct = adding_doubling_totals(stack_at_wavelength(s, t.nm[i]), mu);
    const AddingDoublingTotals& e = t.estimates[i].totals;
    EXPECT_DOUBLE_EQ(e.R_diffuse[0], direct.R_diffuse[0]) << t.nm[i];
    EXPECT_DOUBLE_EQ(e.absorbed[0], direct.absorbed[0]) << t.nm[i];
    EXPECT_NEAR(e.R_specular[0] + e.R_diffuse[0] + e.T_ballistic[0] + e.T_diffuse[0] + e.absorbed[0], 1.0, 1e-12);
  }
  // Skin reflects more red than blue, and more near-infrared than red (melanin and blood fall off).
  EXPECT_LT(t.estimates[0].totals.R_diffuse[0], t.estimates[2].totals.R_diffuse[0]);
  EXPECT_LT(t.estimates[2].totals.R_diffuse[0], t.estimates[4].totals.R_diffuse[0]);

  const SpectralStack grey = parse_spectral_stack_json(
      R"({"lamina_material": 1, "layers": [{"ior": 1.33, "thickness": 0.5, "sigma_a": 0.3, "sigma_s": 5, "g": 0.7}]})", "g.json");
  const AddingDoublingTotals rgb = adding_doubling_totals(grey.stack, mu);
  const SpectralTotals flat = adding_doubling_spectrum(grey, grid, mu);
  for (const AddingDoublingEstimate& e : flat.estimates) {
    EXPECT_DOUBLE_EQ(e.totals.R_diffuse[0], rgb.R_diffuse[0]);
    EXPECT_DOUBLE_EQ(e.totals.T_diffuse[0], rgb.T_diffuse[0]);
  }
}

}  // namespace
}  // namespace lamina

namespace lamina {
namespace {

// A spectrum the model itself made is fitted back: the parameters are recovered from another
// start and the residual vanishes (the optimiser's tolerance, 1e-4 of each range, bounds both).
TEST(SpectralFit, RecoversTheParametersOfASyntheticSpectrum) {
  SpectralStack truth = parse_spectral_stack_json(kSpectralSkin, "skin.json");
  *chromophore_parameter(&truth, "layers[0].chromophores.melanin") = 0.12;
  *chromophore_parameter(&truth, "layers[1].chromophores.blood") = 0.035;
  *chromophore_parameter(&truth, "layers[1].chromophores.scattering.reduced_500") = 3.0;
  std::vector<double> nm;
  for (double w = 400.0; w <= 1000.0; w += 40.0) nm.push_back(w);
  AddingDoublingSettings settings;
  settings.quadrature_points = 8;
  const double mu = std::cos(8.0 * 3.14159265358979323846 / 180.0);
  const std::vector<double> measured = modelled_reflectance(truth, nm, mu, settings);
  const SpectralStack start = parse_spectral_stack_json(kSpectralSkin, "skin.json");  // 0.05, 0.02, 4.6
  const std::vector<FitParameterSpec> params = {{"layers[0].chromophores.melanin", 0.0, 0.4},
                                                {"layers[1].chromophores.blood", 0.0, 0.1},
                                                {"layers[1].chromophores.scattering.reduced_500", 0.5, 10.0}};
  const SpectralFitResult fit = fit_spectrum(start, params, nm, measured, mu, settings);
  EXPECT_NEAR(fit.values[0], 0.12, 0.004);
  EXPECT_NEAR(fit.values[1], 0.035, 0.001);
  EXPECT_NEAR(fit.values[2], 3.0, 0.03);
  EXPECT_LT(fit.rmse, 1e-3);
  EXPECT_EQ(fit.fitted.chromophores[0]->melanin, fit.values[0]);
}

TEST(SpectralFit, NamesBadParameters) {
  SpectralStack s = parse_spectral_stack_json(kSpectralSkin, "skin.json");
  auto message = [&](const std::string& path) {
    try {
      chromophore_parameter(&s, path);
    } catch (const FitError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message("layers[0].sigma_a"), "layers[0].sigma_a: expected layers[i].chromophores.KEY");
  EXPECT_EQ(message("layers[5].chromophores.melanin"), "layers[5].chromophores.melanin: layers[5] is not a layer given by chromophores");
  EXPECT_EQ(message("layers[0].chromophores.scattering.g"),
            "layers[0].chromophores.scattering.g: unknown scattering key (reduced_500, f_rayleigh, b_mie)");
  EXPECT_EQ(message("layers[0].chromophores.bilirubin").rfind("layers[0].chromophores.bilirubin: unknown chromophore key", 0), 0u);
  const std::vector<double> nm = {500.0}, r = {0.3};
  const std::vector<FitParameterSpec> six(6, FitParameterSpec{"layers[0].chromophores.melanin", 0.0, 1.0});
  EXPECT_THROW(fit_spectrum(s, six, nm, r, 1.0), FitError);
  EXPECT_THROW(fit_spectrum(s, {{"layers[0].chromophores.melanin", 0.5, 0.5}}, nm, r, 1.0), FitError);
  EXPECT_THROW(fit_spectrum(s, {{"layers[0].chromophores.melanin", 0.0, 0.5}}, nm, {}, 1.0), FitError);
}

}  // namespace
}  // namespace lamina
