// materials/fit/spectral_fit's optimiser on a measured spectrum (NIST subject 1, whose residual
// does not vanish, unlike the synthetic spectrum of test_chromophores): the result is a minimum
// of the accurate model (no small move of one parameter lowers the sum of squares), the search
// on the coarse model reaches the same minimum as a search on the accurate model alone, and an
// optimum beyond a bound stops on the bound with the other parameters at their optimum there.
// leaf_spectra (the layered leaf's batched model): the batch gives each stack's own cone-averaged
// totals, and a rough leaf that holds no absorber loses no light.
#include "materials/fit/spectral_fit.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

const double kCos8 = std::cos(8.0 * 3.14159265358979323846 / 180.0);

// scripts/nist_skin_fit.py's five parameters.
const std::vector<FitParameterSpec> kParameters = {
    {"layers[0].chromophores.melanin", 0.0, 0.5},   {"layers[0].chromophores.eumelanin", 0.0, 1.0},
    {"layers[1].chromophores.blood", 0.0, 0.1},     {"layers[1].chromophores.oxygenation", 0.0, 1.0},
    {"layers[1].chromophores.scattering.reduced_500", 0.5, 10.0}};

SpectralStack skin() { return load_spectral_stack(std::string(LAMINA_SOURCE_DIR) + "/scenes/spectral/skin_spectral.json"); }

// Every other wavelength (400-1000 nm every 20 nm) of subject `s` of the NIST set.
void nist_subject(int s, std::vector<double>* nm, std::vector<double>* r) {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/data/nist_skin/nist_skin_reflectance.csv");
  ASSERT_TRUE(in.good());
  std::string line;
  bool header = true;
  for (int row = 0; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    if (row++ % 2 != 0) continue;
    std::stringstream ss(line);
    std::string f;
    for (int k = 0; std::getline(ss, f, ','); ++k) {
      if (k == 0) nm->push_back(std::stod(f));
      if (k == s) r->push_back(std::stod(f));
    }
  }
  ASSERT_EQ(nm->size(), 31u);
  ASSERT_EQ(r->size(), 31u);
}

double sum_of_squares(const SpectralStack& stack, const std::vector<double>& nm, const std::vector<double>& measured,
                      const AddingDoublingSettings& settings) {
  const std::vector<double> m = modelled_reflectance(stack, nm, kCos8, settings);
  double s = 0.0;
  for (std::size_t i = 0; i < m.size(); ++i) s += (m[i] - measured[i]) * (m[i] - measured[i]);
  return s;
}

// A minimum: moving any one parameter by 1e-3 of its range, either way within the bounds, does
// not lower the sum of squares by more than its rounding (1e-12 of it). The optimiser stops
// when its step is below 1e-5 of the ranges, where the gradient is ~1e-5 of the curvature: a
// move 100 times larger raises the sum (by the curvature's term) far more than the gradient's
// term could lower it; a search stopped early (at 1e-2, say) fails this.
void expect_minimum(const SpectralFitResult& fit, const std::vector<double>& nm, const std::vector<double>& measured,
                    const AddingDoublingSettings& settings) {
  const double at = sum_of_squares(fit.fitted, nm, measured, settings);
  EXPECT_NEAR(std::sqrt(at / static_cast<double>(nm.size())), fit.rmse, 1e-12);
  for (std::size_t k = 0; k < kParameters.size(); ++k)
    for (double sign : {-1.0, 1.0}) {
      const FitParameterSpec& p = kParameters[k];
      SpectralStack moved = fit.fitted;
      double* v = chromophore_parameter(&moved, p.path);
      const double target = *v + sign * 1e-3 * (p.upper - p.lower);
      if (target < p.lower || target > p.upper) continue;
      *v = target;
      EXPECT_GE(sum_of_squares(moved, nm, measured, settings), at * (1.0 - 1e-12)) << p.path << " " << sign;
    }
}

TEST(SpectralFitOptimiser, CoarseSearchReachesTheAccurateMinimum) {
  std::vector<double> nm, measured;
  nist_subject(1, &nm, &measured);
  AddingDoublingSettings settings;
  settings.quadrature_points = 8;
  const SpectralFitResult coarse = fit_spectrum(skin(), kParameters, nm, measured, kCos8, settings, 4);
  const SpectralFitResult accurate = fit_spectrum(skin(), kParameters, nm, measured, kCos8, settings, 0);
  EXPECT_GT(coarse.coarse_evaluations, 0);
  EXPECT_LT(coarse.coarse_evaluations, coarse.evaluations);
  EXPECT_EQ(accurate.coarse_evaluations, 0);
  expect_minimum(coarse, nm, measured, settings);
  expect_minimum(accurate, nm, measured, settings);
  // The same minimum: the sums of squares agree to the optimiser's stopping rule (a relative
  // decrease below 1e-10, or a step below 1e-5 of the ranges, whose effect on the sum is of the
  // order of (1e-5)^2 of the curvature).
  EXPECT_NEAR(coarse.rmse, accurate.rmse, 1e-6 * accurate.rmse);
  EXPECT_GT(coarse.rmse, 0.005);  // a measured spectrum: the model does not pass through it
}

// Melanin's optimum for a spectrum made with melanin 0.12 lies beyond an upper bound of 0.08:
// the fit stops there, and the other parameters are where a fit with melanin held at 0.08 (not
// an unknown) puts them.
TEST(SpectralFitOptimiser, StopsOnTheBoundBeyondWhichTheOptimumLies) {
  AddingDoublingSettings settings;
  settings.quadrature_points = 8;
  SpectralStack truth = skin();
  *chromophore_parameter(&truth, "layers[0].chromophores.melanin") = 0.12;
  *chromophore_parameter(&truth, "layers[1].chromophores.blood") = 0.01;
  std::vector<double> nm;
  for (double w = 400.0; w <= 1000.0; w += 40.0) nm.push_back(w);
  const std::vector<double> measured = modelled_reflectance(truth, nm, kCos8, settings);
  const std::vector<FitParameterSpec> bounded = {{"layers[0].chromophores.melanin", 0.0, 0.08},
                                                 {"layers[1].chromophores.blood", 0.0, 0.1},
                                                 {"layers[1].chromophores.scattering.reduced_500", 0.5, 10.0}};
  const SpectralFitResult fit = fit_spectrum(skin(), bounded, nm, measured, kCos8, settings);
  EXPECT_EQ(fit.values[0], 0.08);
  SpectralStack held = skin();
  *chromophore_parameter(&held, "layers[0].chromophores.melanin") = 0.08;
  const SpectralFitResult two = fit_spectrum(held, {bounded[1], bounded[2]}, nm, measured, kCos8, settings);
  EXPECT_NEAR(fit.values[1], two.values[0], 1e-4 * 0.1);
  EXPECT_NEAR(fit.values[2], two.values[1], 1e-4 * 9.5);
  EXPECT_NEAR(fit.rmse, two.rmse, 1e-6 * two.rmse);
  EXPECT_GT(fit.rmse, 1e-3);  // the bound keeps the fit away from the truth
}

// A three-layer leaf under an energy-conserving rough cuticle (alpha 0.4), laid out as scripts/leaf_fit.py
// writes it, with `contents` in the palisade and the spongy mesophyll, loaded from a file.
SpectralStack rough_leaf(const std::string& name, const std::string& contents, double plates) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / ("lamina_test_leaf_" + name + ".json");
  std::ofstream(path) << R"({"lamina_material": 1, "roughness": 0.4, "interface_model": "energy_conserving", "layers": [
      {"thickness": 0.003, "leaf": {}},
      {"thickness": 0.1, "leaf": {)" << contents << R"("plates": )" << plates << R"(, "g": 0.95}},
      {"thickness": 0.12, "leaf": {)" << contents << R"("plates": )" << plates << R"(, "g": 0.95}}]})";
  SpectralStack s = load_spectral_stack(path.string());
  std::filesystem::remove(path);
  return s;
}

// Two stacks that share the rough cuticle (one projection per wavelength serves both) give what
// each gives alone: the weighted totals of adding_doubling_totals per incidence, exactly.
TEST(LeafSpectra, EachStackOfTheBatchAsAlone) {
  const std::vector<SpectralStack> stacks = {rough_leaf("a", R"("chlorophyll": 20, "water": 0.005, )", 0.5),
                                             rough_leaf("b", R"("chlorophyll": 5, "dry_matter": 0.002, )", 1.5)};
  const std::vector<double> nm = {450.0, 680.0, 1450.0}, cosines = {1.0, 0.8}, weights = {0.3, 0.7};
  AddingDoublingSettings settings;
  settings.quadrature_points = 6;
  const LeafSpectra batch = leaf_spectra(stacks, nm, cosines, weights, settings);
  settings.only_channel = 0;
  for (std::size_t k = 0; k < stacks.size(); ++k)
    for (std::size_t i = 0; i < nm.size(); ++i) {
      double r = 0.0, t = 0.0;
      for (std::size_t a = 0; a < cosines.size(); ++a) {
        const AddingDoublingTotals alone = adding_doubling_totals(stack_at_wavelength(stacks[k], nm[i]), cosines[a], settings);
        r += weights[a] * (alone.R_specular[0] + alone.R_diffuse[0]);
        t += weights[a] * (alone.T_ballistic[0] + alone.T_diffuse[0]);
      }
      EXPECT_EQ(batch.r[k][i], r) << "stack " << k << ", " << nm[i] << " nm";
      EXPECT_EQ(batch.t[k][i], t) << "stack " << k << ", " << nm[i] << " nm";
      EXPECT_GT(t, 0.0);
    }
  // The contents differ: so do the spectra (a batch that solved one stack twice would fail).
  EXPECT_GT(std::abs(batch.r[0][1] - batch.r[1][1]), 0.01);
}

// Without absorbers the rough leaf (energy-conserving cuticle, scattering mesophyll, smooth
// bottom) reflects or transmits all the light at every wavelength and incidence; the plates
// scatter, so R grows with them.
TEST(LeafSpectra, RoughLeafWithoutAbsorbersLosesNoLight) {
  AddingDoublingSettings settings;
  settings.quadrature_points = 6;
  const std::vector<double> nm = {400.0, 1000.0, 2500.0};  // the index 1.53 to 1.27
  const LeafSpectra clear = leaf_spectra({rough_leaf("c", "", 0.5), rough_leaf("d", "", 2.0)}, nm, {1.0, 0.5}, {0.5, 0.5}, settings);
  for (std::size_t k = 0; k < 2; ++k)
    for (std::size_t i = 0; i < nm.size(); ++i) EXPECT_NEAR(clear.r[k][i] + clear.t[k][i], 1.0, 1e-9) << k << ", " << nm[i];
  for (std::size_t i = 0; i < nm.size(); ++i) EXPECT_GT(clear.r[1][i], clear.r[0][i] + 0.05);
  EXPECT_THROW(leaf_spectra({}, nm, {1.0}, {0.5, 0.5}, settings), std::invalid_argument);
}

}  // namespace
}  // namespace lamina
