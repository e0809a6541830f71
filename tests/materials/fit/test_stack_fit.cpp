// lamina fit's library (materials/fit/stack_fit): round trips (the forward model at known values,
// Gaussian noise of the stated sigma, fit) recover the values within their reported sigmas and
// the pulls (fit - truth) / sigma have a spread of about 1 and chi^2 a mean of about dof, which
// checks the uncertainties themselves; unidentifiable parameters are reported; the fitted
// material file parses back to the fitted stack; bad input gives one-line errors.
#include "materials/fit/stack_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

// A slab (0.2 mm, n = 1.4, in air): an iad-like sample, different optics per channel, thin
// enough (optical thickness 1.7 to 3.4) that the unscattered beam is measurable: with it, R and T
// identify sigma_a, sigma_s and g (without it, g is only weakly identified in a thick slab:
// sigma_s and g then act almost only through sigma_s (1 - g)).
const char* kSlab = R"({"lamina_material": 1, "layers": [
  {"ior": 1.4, "thickness": 0.2, "sigma_a": [0.3, 1.0, 2.0], "sigma_s": [8.0, 12.0, 15.0], "g": [0.7, 0.8, 0.85]}],
  "below": {"ior": 1.0}})";

std::vector<FitMeasurement> design(bool unscattered, bool diffuse) {
  std::vector<FitMeasurement> d;
  for (int c = 0; c < kChannels; ++c) {
    auto add = [&](FitQuantity q, bool dif) {
      FitMeasurement m;
      m.quantity = q;
      m.channel = c;
      m.diffuse = dif;
      m.sigma = 1e-3;
      d.push_back(m);
    };
    add(FitQuantity::kR, false);
    add(FitQuantity::kT, false);
    if (unscattered) add(FitQuantity::kTUnscattered, false);
    if (diffuse) {
      add(FitQuantity::kR, true);
      add(FitQuantity::kT, true);
    }
  }
  return d;
}

// The measurements' values for the template's stack by the fit's own forward model (so that the
// round trips test the statistics; the discretisation has its own test), plus N(0, sigma) noise
// (seed 0: none).
// 8 points: the round trips test the statistics, and 8 points are ~5x faster than the default.
const AddingDoublingSettings kRoundTripModel{8};
void simulate(const StackTemplate& t, std::vector<FitMeasurement>* d, unsigned seed) {
  const std::vector<double> m = fit_model_values(t.stack, *d, kRoundTripModel);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  for (std::size_t i = 0; i < d->size(); ++i) (*d)[i].value = m[i] + (seed ? (*d)[i].sigma * normal(rng) : 0.0);
}

const std::vector<FitParameterSpec> kSlabSpecs = {
    {"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 50.0}, {"layers[0].g", 0.0, 0.95}};

// The round trips' data come from the fit's own forward model, so its discretisation (at
// sigma 1e-3 it is ~0.2 sigma of this slab at 8 points, which the fit would rightly report)
// is not part of what they test.
FitSettings same_model() {
  FitSettings s;
  s.forward = kRoundTripModel;
  s.check_discretisation = false;
  return s;
}

double truth(const StackTemplate& t, const FitUnknown& u) {
  const StackParameter p = parse_stack_parameter(t, kSlabSpecs[u.parameter].path);
  return p.template_value(t)[u.channel < 0 ? 0 : u.channel];
}

// The per-channel fits rely on AddingDoublingSettings::only_channel giving that channel's totals
// of the all-channel solution (the channels are independent problems in the solver).
TEST(StackFit, OneChannelSolutionEqualsThatChannelOfAll) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  const AddingDoublingTotals all = adding_doubling_totals(t.stack, 0.8);
  for (int c = 0; c < kChannels; ++c) {
    AddingDoublingSettings s;
    s.only_channel = c;
    const AddingDoublingTotals one = adding_doubling_totals(t.stack, 0.8, s);
    EXPECT_EQ(one.R_diffuse[c], all.R_diffuse[c]);
    EXPECT_EQ(one.T_diffuse[c], all.T_diffuse[c]);
    EXPECT_EQ(one.R_hemispherical[c], all.R_hemispherical[c]);
    EXPECT_EQ(one.T_hemispherical[c], all.T_hemispherical[c]);
    EXPECT_EQ(one.T_ballistic[c], all.T_ballistic[c]);
  }
}

TEST(StackFit, NoiseFreeRoundTripRecoversTheValues) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  std::vector<FitMeasurement> d = design(true, true);
  simulate(t, &d, 0);
  // Start away from the truth: the bounds' midpoints are not the truth, so set a start by
  // fitting a template with other values.
  StackTemplate start = t;
  start.layers[0].components[0].sigma_a = Spectrum(1.5);
  start.layers[0].components[0].sigma_s = Spectrum(20.0);
  start.layers[0].components[0].g = Spectrum(0.5);
  mix_layer(start.layers[0], &start.stack.layers[0]);
  const FitResult r = fit_stack(start, kSlabSpecs, d, same_model());
  ASSERT_EQ(r.unknowns.size(), 9u);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  for (std::size_t k = 0; k < r.unknowns.size(); ++k)
    EXPECT_NEAR(r.value[k], truth(t, r.unknowns[k]), 0.03 * r.sigma[k])
        << r.unknowns[k].name;
  EXPECT_LT(r.chi2, 1e-4);
}

// Noise of the stated sigma: each recovered value within 4 sigma of the truth (a 4-sigma miss
// has probability 6e-5 per unknown), the pulls' spread 1 within its sampling error, chi^2's
// mean equal to dof within its sampling error (var chi^2 = 2 dof).
TEST(StackFit, NoisyRoundTripsHavePullsOfUnitSpread) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  const int seeds = 12;
  double sum2 = 0.0, chi2 = 0.0;
  int n = 0, dof = 0;
  for (int s = 1; s <= seeds; ++s) {
    std::vector<FitMeasurement> d = design(true, true);
    simulate(t, &d, static_cast<unsigned>(s));
    const FitResult r = fit_stack(t, kSlabSpecs, d, same_model());
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
    for (std::size_t k = 0; k < r.unknowns.size(); ++k) {
      const double pull = (r.value[k] - truth(t, r.unknowns[k])) / r.sigma[k];
      EXPECT_LT(std::abs(pull), 4.0) << "seed " << s << " " << r.unknowns[k].name;
      sum2 += pull * pull;
      ++n;
    }
    chi2 += r.chi2;
    dof = r.dof;
  }
  // The pulls within a fit are correlated, but their mean square is still 1 in expectation; its
  // spread is about sqrt(2 / n) for independent pulls; correlation widens it, so 4 of those.
  const double rms = std::sqrt(sum2 / n);
  std::printf("%d pulls: rms %.3f; chi2 mean %.2f for dof %d over %d seeds\n", n, rms, chi2 / seeds, dof, seeds);
  EXPECT_NEAR(rms, 1.0, 4.0 * std::sqrt(0.5 / n)) << n << " pulls";
  EXPECT_EQ(dof, 15 - 9);
  EXPECT_NEAR(chi2 / seeds, dof, 4.0 * std::sqrt(2.0 * dof / seeds));
}

// g from R and T alone: three unknowns per channel, two measurements: J^T W J is singular.
TEST(StackFit, GFromRAndTAloneIsReportedUnidentified) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  std::vector<FitMeasurement> d = design(false, false);
  for (FitMeasurement& m : d) m.channel = 0;  // one channel, R and T thrice: still 2 distinct
  d.resize(2);
  simulate(t, &d, 0);
  const FitResult r = fit_stack(t, kSlabSpecs, d);
  ASSERT_FALSE(r.warnings.empty());
  bool named_g = false;
  for (const std::string& w : r.warnings) {
    EXPECT_EQ(w.find('\n'), std::string::npos);
    if (w.find("layers[0].g[r]") != std::string::npos && w.find("not identified") != std::string::npos) named_g = true;
  }
  EXPECT_TRUE(named_g) << r.warnings.front();
  for (std::size_t k = 0; k < r.unknowns.size(); ++k) {
    if (r.unknowns[k].name == "layers[0].g[r]") {
      EXPECT_TRUE(std::isinf(r.sigma[k]));
    }
  }
}

// A parameter the data do not see: g of a layer that does not scatter.
TEST(StackFit, ParameterWithoutEffectIsReported) {
  const StackTemplate t = parse_stack_template_json(
      R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 1.0, "sigma_a": 1.0, "sigma_s": 0.0, "g": 0.5}]})", "clear");
  std::vector<FitMeasurement> d = design(false, false);
  simulate(t, &d, 0);
  const FitResult r = fit_stack(t, {{"layers[0].g", -0.9, 0.9}, {"layers[0].sigma_a", 0.0, 5.0}}, d);
  bool found = false;
  for (const std::string& w : r.warnings)
    found |= w == "layers[0].g[r]: not identified: the measurements do not depend on it";
  EXPECT_TRUE(found) << (r.warnings.empty() ? "no warning" : r.warnings.front());
  for (std::size_t k = 0; k < r.unknowns.size(); ++k)
    if (r.unknowns[k].name.find("sigma_a") != std::string::npos) {
      EXPECT_NEAR(r.value[k], 1.0, 1e-4);
      EXPECT_TRUE(std::isfinite(r.sigma[k]));
    }
}

// A composite layer's fraction (the skin preset's blood in the dermis) fitted from diffuse
// reflectance; the written file parses back to the fitted stack (fractions rescaled as the
// renderer's parameters do).
TEST(StackFit, FittedFileParsesToTheFittedStack) {
  const std::string text = R"({"lamina_material": 1, "layers": [
    {"ior": 1.4, "thickness": 1.5, "components": [
      {"fraction": 0.05, "sigma_a": [0.65, 24.4, 39.1], "sigma_s": [15.8, 20.1, 26.7], "g": 0.8},
      {"fraction": 0.95, "sigma_a": [0.03, 0.05, 0.12], "sigma_s": [15.8, 20.1, 26.7], "g": 0.8}]}],
    "below": {"lambert": [0.8, 0.55, 0.45]}})";
  const StackTemplate t = parse_stack_template_json(text, "dermis");
  std::vector<FitMeasurement> d = design(false, false);
  d.erase(std::remove_if(d.begin(), d.end(), [](const FitMeasurement& m) { return m.quantity != FitQuantity::kR; }), d.end());
  simulate(t, &d, 0);
  StackTemplate start = parse_stack_template_json(text, "dermis");
  const std::vector<FitParameterSpec> specs = {{"layers[0].components[0].fraction", 0.0, 0.5}};
  // Start from another fraction: the template says 0.05; fit from a file that says 0.2.
  nlohmann::json j = nlohmann::json::parse(text);
  j["layers"][0]["components"][0]["fraction"] = 0.2;
  j["layers"][0]["components"][1]["fraction"] = 0.8;
  start = parse_stack_template_json(j.dump(), "start");
  const FitResult r = fit_stack(start, specs, d);
  ASSERT_EQ(r.unknowns.size(), 1u);
  EXPECT_NEAR(r.value[0], 0.05, 1e-4);
  write_fitted_values(j, start, specs, r);
  const LayerStack back = parse_stack_json(j.dump(), "fitted");
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_NEAR(back.layers[0].sigma_a[c], r.stack.layers[0].sigma_a[c], 1e-12);
    EXPECT_NEAR(j["layers"][0]["components"][0]["fraction"].get<double>() + j["layers"][0]["components"][1]["fraction"].get<double>(), 1.0, 1e-12);
  }
}

// Data from a finer solution than the fit's, with sigmas small enough that the fit's 8 points
// bias it: the fit says so.
TEST(StackFit, CoarseQuadratureAgainstPreciseDataIsReported) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  std::vector<FitMeasurement> d = design(true, true);
  const std::vector<double> m = fit_model_values(t.stack, d, AddingDoublingSettings{32});
  for (std::size_t i = 0; i < d.size(); ++i) {
    d[i].value = m[i];
    d[i].sigma = 1e-5;
    d[i].where = "m.csv: line " + std::to_string(i + 2);
  }
  const FitResult r = fit_stack(t, kSlabSpecs, d);
  bool found = false;
  std::string all;
  for (const std::string& w : r.warnings) {
    found |= w.find("quadrature points differs from") != std::string::npos;
    all += w + "\n";
  }
  EXPECT_TRUE(found) << all;
}

// iadpython 0.5.3's inversion of single slabs (scripts/iad_inversion_reference.py writes
// tests/data/iad_inversion_reference.csv): sigma_a and sigma_s from R and T at normal incidence,
// g and n known. The forward models agree to 2.8e-5 in the totals (docs/validation.md, "Adding-doubling") and
// iad met its (r, t) to 5e-6, so with sigma 1e-4 on R and T the two inversions may differ by a
// fraction of the fit's sigmas: within 1 sigma.
TEST(StackFit, AgreesWithIadpythonInversion) {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/tests/data/iad_inversion_reference.csv");
  ASSERT_TRUE(in) << "tests/data/iad_inversion_reference.csv missing";
  std::string line;
  std::getline(in, line);  // header
  int cases = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    ASSERT_EQ(f.size(), 13u) << line;
    const double r = std::stod(f[1]), t_ = std::stod(f[2]);
    const double sa = std::stod(f[9]), ss_ = std::stod(f[10]);
    const StackTemplate t = parse_stack_template_json(
        R"({"lamina_material": 1, "layers": [{"ior": )" + f[4] + R"(, "thickness": )" + f[5] +
            R"(, "sigma_a": 1.0, "sigma_s": 10.0, "g": )" + f[3] + "}]}", f[0]);
    std::vector<FitMeasurement> d(2);
    d[0].quantity = FitQuantity::kR;
    d[0].value = r;
    d[1].quantity = FitQuantity::kT;
    d[1].value = t_;
    for (FitMeasurement& m : d) m.sigma = 1e-4;
    FitSettings settings;
    settings.forward.quadrature_points = 16;
    const FitResult fit = fit_stack(t, {{"layers[0].sigma_a", 0.0, 20.0}, {"layers[0].sigma_s", 0.0, 100.0}}, d, settings);
    ASSERT_EQ(fit.unknowns.size(), 2u);
    EXPECT_TRUE(fit.warnings.empty()) << fit.warnings.front();
    std::printf("%s: sigma_a %.6f (iad %.6f, %.2f sigma), sigma_s %.5f (iad %.5f, %.2f sigma)\n", f[0].c_str(), fit.value[0], sa,
                (fit.value[0] - sa) / fit.sigma[0], fit.value[1], ss_, (fit.value[1] - ss_) / fit.sigma[1]);
    EXPECT_NEAR(fit.value[0], sa, fit.sigma[0]) << f[0] << " sigma_a";
    EXPECT_NEAR(fit.value[1], ss_, fit.sigma[1]) << f[0] << " sigma_s";
    EXPECT_LT(fit.chi2, 0.01) << f[0];
    ++cases;
  }
  EXPECT_EQ(cases, 4);
}

// The default search runs on a coarse model (4 points) corrected towards the accurate one
// (FitSettings::coarse_quadrature_points, stack_fit.cpp fit_group); it must land where a search
// on the accurate model alone lands. Both stop by the same rules (chi^2 within ~1e-6 of its
// minimum between steps, i.e. ~1e-3 sigma along each direction), and the correction's last
// Gauss-Newton step leaves an error of second order in its size (~1e-2 sigma): so the two fits
// must agree to 0.02 sigma (without that step they differ by up to 0.03 sigma on these cases;
// with it by 3e-3), their sigmas to 1% and their chi^2 to 1e-3. Data from the 16-point model
// with noise (dof 6 per channel: residuals that the coarse model's Jacobian would weigh wrongly)
// and, without noise, a forward-peaked thick slab from R and T (g = 0.9: the 4-point model is
// off by several sigma there, so the correction has to carry the fit).
TEST(StackFit, CoarseSearchWithCorrectionAgreesWithTheAccurateSearch) {
  const StackTemplate slab = parse_stack_template_json(kSlab, "slab");
  const StackTemplate thick = parse_stack_template_json(
      R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 1.0, "sigma_a": 0.25, "sigma_s": 42.0, "g": 0.9}]})", "thick");
  struct Case {
    const StackTemplate* t;
    std::vector<FitParameterSpec> specs;
    std::vector<FitMeasurement> data;
    unsigned seed;
  };
  std::vector<Case> cases;
  for (unsigned seed : {1u, 2u, 3u}) cases.push_back({&slab, kSlabSpecs, design(true, true), seed});
  std::vector<FitMeasurement> rt = design(false, false);
  rt.resize(2);  // R and T, red
  cases.push_back({&thick, {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 100.0}}, rt, 0});
  const AddingDoublingSettings accurate{16};
  for (Case& c : cases) {
    const std::vector<double> m = fit_model_values(c.t->stack, c.data, accurate);
    std::mt19937_64 rng(c.seed);
    std::normal_distribution<double> normal;
    for (std::size_t i = 0; i < c.data.size(); ++i)
      c.data[i].value = m[i] + (c.seed ? c.data[i].sigma * normal(rng) : 0.0);
    // Start away from the truth (the template's values are the truth).
    StackTemplate start = *c.t;
    start.layers[0].components[0].sigma_a = Spectrum(1.5);
    start.layers[0].components[0].sigma_s = Spectrum(20.0);
    mix_layer(start.layers[0], &start.stack.layers[0]);
    FitSettings full;
    full.coarse_quadrature_points = 0;
    const FitSettings fast;  // the default: coarse search, corrected
    ASSERT_EQ(fast.forward.quadrature_points, 16);
    ASSERT_GT(fast.coarse_quadrature_points, 0);
    const FitResult a = fit_stack(start, c.specs, c.data, full), b = fit_stack(start, c.specs, c.data, fast);
    EXPECT_EQ(a.coarse_evaluations, 0);
    EXPECT_GT(b.coarse_evaluations, 0);
    EXPECT_LT(b.evaluations - b.coarse_evaluations, a.evaluations / 3);  // the point of it
    EXPECT_TRUE(b.warnings.empty()) << b.warnings.front();
    ASSERT_EQ(a.value.size(), b.value.size());
    for (std::size_t k = 0; k < a.value.size(); ++k) {
      EXPECT_NEAR(b.value[k], a.value[k], 0.02 * a.sigma[k]) << "seed " << c.seed << " " << a.unknowns[k].name;
      EXPECT_NEAR(b.sigma[k], a.sigma[k], 0.01 * a.sigma[k]) << "seed " << c.seed << " " << a.unknowns[k].name;
    }
    EXPECT_NEAR(b.chi2, a.chi2, 1e-3) << "seed " << c.seed;
    for (std::size_t i = 0; i < c.data.size(); ++i) EXPECT_NEAR(b.residual[i], a.residual[i], 0.02);
  }
}

// A BRDF/BTDF table as measurements: the table of a slab by adding-doubling at 16 points,
// written in lamina brdf's CSV layout (docs/contracts.md; %.9g), Gaussian noise of each bin's stated stderr (2% of the value
// plus 1e-4 /sr), parsed back and fitted for sigma_a, sigma_s and g of the red channel. The bins
// see the phase function's shape, so g is identified (from R and T alone it is not: the test
// above); each value within 4 sigma of the truth, and the pulls' spread 1 within 4 of its
// sampling errors; chi^2 per bin near 1 (mean over seeds within 4 of its sampling errors).
std::string table_csv_text(const BrdfTable& t, const std::vector<Spectrum>& value, const std::vector<Spectrum>& stderr_) {
  std::string out = "side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple\n";
  char buf[256];
  static const char* kCh[] = {"r", "g", "b"};
  for (int side = 0; side < 2; ++side)
    for (int k = 0; k < t.options.bins_theta; ++k)
      for (int m = 0; m < t.options.bins_phi; ++m) {
        const int b = t.bin_index(static_cast<BrdfSide>(side), k, m);
        for (int c = 0; c < kChannels; ++c) {
          std::snprintf(buf, sizeof buf, "%s,%s,%.9g,%.9g,%.9g,%.9g,0,%.9g\n", side == 0 ? "reflect" : "transmit", kCh[c],
                        t.theta_centre_deg(k), t.phi_centre_deg(m), value[b][c], stderr_[b][c], value[b][c]);
          out += buf;
        }
      }
  return out;
}

TEST(StackFit, BrdfTableRoundTripsIdentifyG) {
  const StackTemplate t = parse_stack_template_json(
      R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.5, "sigma_a": 0.5, "sigma_s": 10.0, "g": 0.7}]})", "slab");
  BrdfOptions o;
  o.theta_i_deg = 30.0;
  o.bins_theta = 6;
  o.bins_phi = 12;
  AddingDoublingSettings ad;
  ad.single_scattering_bins = false;
  const BrdfTable table = brdf_table_adding_doubling(t.stack, o, ad);
  StackTemplate start = t;
  start.layers[0].components[0].sigma_a = Spectrum(1.5);
  start.layers[0].components[0].sigma_s = Spectrum(20.0);
  start.layers[0].components[0].g = Spectrum(0.4);
  mix_layer(start.layers[0], &start.stack.layers[0]);
  const std::vector<FitParameterSpec> specs = {
      {"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 100.0}, {"layers[0].g", 0.0, 0.95}};
  const double truth[3] = {0.5, 10.0, 0.7};
  const int seeds = 4;
  double sum2 = 0.0, chi2 = 0.0;
  int n = 0, dof = 0;
  for (int seed = 0; seed <= seeds; ++seed) {  // seed 0: no noise
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal;
    std::vector<Spectrum> value = table.value, err = table.value;
    for (std::size_t b = 0; b < value.size(); ++b)
      for (int c = 0; c < kChannels; ++c) {
        err[b][c] = 0.02 * std::abs(table.value[b][c]) + 1e-4;
        value[b][c] = table.value[b][c] + (seed ? err[b][c] * normal(rng) : 0.0);
      }
    std::vector<FitMeasurement> d = parse_fit_table(table_csv_text(table, value, err), "t.csv", 30.0, 0.0);
    ASSERT_EQ(d.size(), 2u * 6 * 12 * 3);
    EXPECT_EQ(d[0].bins_theta, 6);
    EXPECT_EQ(d[0].bins_phi, 12);
    d.erase(std::remove_if(d.begin(), d.end(), [](const FitMeasurement& m) { return m.channel != 0; }), d.end());
    const FitResult r = fit_stack(start, specs, d);
    ASSERT_EQ(r.unknowns.size(), 3u);
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(std::isfinite(r.sigma[k])) << r.unknowns[k].name;
      const double pull = (r.value[k] - truth[k]) / r.sigma[k];
      if (seed == 0) {  // the CSV's 9 digits and the fit's stopping rule: a small fraction of sigma
        EXPECT_LT(std::abs(pull), 0.03) << r.unknowns[k].name;
        continue;
      }
      EXPECT_LT(std::abs(pull), 4.0) << "seed " << seed << " " << r.unknowns[k].name;
      sum2 += pull * pull;
      ++n;
    }
    if (seed == 0) continue;
    chi2 += r.chi2;
    dof = r.dof;
  }
  const double rms = std::sqrt(sum2 / n);
  std::printf("table fits: %d pulls, rms %.3f; chi2 mean %.1f for dof %d\n", n, rms,
              chi2 / seeds, dof);
  EXPECT_NEAR(rms, 1.0, 4.0 * std::sqrt(0.5 / n));
  EXPECT_NEAR(chi2 / seeds, dof, 4.0 * std::sqrt(2.0 * dof / seeds));
}

TEST(StackFit, BadTablesAreOneLineErrors) {
  const std::string header = "side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple\n";
  auto error = [](const std::string& text, double floor) {
    try {
      parse_fit_table(text, "t.csv", 30.0, floor);
    } catch (const FitError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // One ring and one azimuth: the 1 x 1 grid's centre is (60 deg, 180 deg).
  EXPECT_EQ(error(header + "reflect,r,60,180,0.1,0.01,0,0.1\n", 0.0), "no error");
  EXPECT_EQ(error(header + "reflect,r,50,180,0.1,0.01,0,0.1\n", 0.0).find("t.csv: line 2: (theta_o, phi_o) = (50, 180) is not a bin centre"), 0u);
  EXPECT_EQ(error(header + "reflect,r,60,180,0.1,0,0,0.1\n", 0.0).find("t.csv: line 2: stderr is 0 and no sigma floor"), 0u);
  EXPECT_EQ(error(header + "reflect,r,60,180,0.1,0,0,0.1\n", 0.01), "no error");
  EXPECT_EQ(error(header + "up,r,60,180,0.1,0.01,0,0.1\n", 0.0), "t.csv: line 2: side 'up' is not reflect or transmit");
  EXPECT_EQ(error("side,channel,theta_o_deg,phi_o_deg,value\n", 0.0), "t.csv: line 1: missing column 'stderr' (a lamina brdf table)");
  EXPECT_EQ(error(header + "reflect,r,60,180,nan,0.01,0,0.1\n", 0.0), "t.csv: line 2: value 'nan' is not a finite decimal number");
  // The one decimal parser and the ranges that keep chi^2 finite (materials/stack/decimal.h).
  EXPECT_EQ(error(header + "reflect,r,60,180,0x10,0.01,0,0.1\n", 0.0), "t.csv: line 2: value '0x10' is not a finite decimal number");
  EXPECT_EQ(error(header + "reflect,r,60,180,1e300,0.01,0,0.1\n", 0.0), "t.csv: line 2: value '1e300' is not in [-1e+06, 1e+06]");
  EXPECT_EQ(error(header + "reflect,r,60,180,0.1,1e-320,0,0.1\n", 0.0).find("t.csv: line 2: stderr '1e-320' is too small"), 0u);
  EXPECT_EQ(error(header + "reflect,r,60,180,0.1,1e-200,0,0.1\n", 0.0).find("t.csv: line 2: the bin's sigma"), 0u);
  EXPECT_EQ(error(header, 0.0), "t.csv: no bins after the header");
}

// A correction cut short is said: the g = 0.9 slab, whose 4-point model is several sigma off,
// with no correction allowed.
TEST(StackFit, UnsettledCorrectionIsReported) {
  const StackTemplate thick = parse_stack_template_json(
      R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 1.0, "sigma_a": 0.25, "sigma_s": 42.0, "g": 0.9}]})", "thick");
  std::vector<FitMeasurement> d = design(false, false);
  d.resize(2);
  const std::vector<double> m = fit_model_values(thick.stack, d, AddingDoublingSettings{16});
  for (std::size_t i = 0; i < d.size(); ++i) d[i].value = m[i];
  FitSettings s;
  s.max_corrections = 0;
  const FitResult r = fit_stack(thick, {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 100.0}}, d, s);
  bool found = false;
  for (const std::string& w : r.warnings) found |= w.find("the coarse model's correction did not settle in 0 steps") == 0;
  EXPECT_TRUE(found) << (r.warnings.empty() ? "no warning" : r.warnings.front());
  s.max_corrections = FitSettings{}.max_corrections;
  EXPECT_TRUE(fit_stack(thick, {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 100.0}}, d, s).warnings.empty());
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const FitError& e) {
    return e.what();
  }
  return "no error";
}

TEST(StackFit, AnOptimiserOutOfEvaluationsIsReported) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  std::vector<FitMeasurement> d = design(false, false);
  simulate(t, &d, 0);
  FitSettings s = same_model();
  s.max_evaluations = 5;
  const FitResult r = fit_stack(t, {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 50.0}}, d, s);
  bool found = false;
  for (const std::string& w : r.warnings) found |= w.find("the optimiser stopped after 5 solutions") == 0;
  EXPECT_TRUE(found);
}

TEST(StackFit, BadParametersAreOneLineErrors) {
  const StackTemplate t = parse_stack_template_json(kSlab, "slab");
  std::vector<FitMeasurement> d = design(false, false);
  simulate(t, &d, 0);
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"layers[3].thickness", 0.0, 1.0}}, d); }),
            "layers[3].thickness: the stack has 1 layer(s) (layers[0] .. layers[0])");
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"layers[0].thickness", 2.0, 1.0}}, d); }),
            "layers[0].thickness: the lower bound 2 is not below the upper bound 1");
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"layers[0].g", -2.0, 0.5}}, d); }).find("layers[0].g: bounds -2:0.5 leave"), 0u);
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"layers[0].thickness", 0.0, INFINITY}}, d); }),
            "layers[0].thickness: bounds must be finite, got 0:inf");
}

// Rough interfaces are in the forward model (adding-doubling with the interfaces projected onto
// its basis). A transmitting slab under an energy-conserving rough top (a leaf's cuticle: what
// the single-scattering model cannot do), its totals at two angles and under diffuse light made
// by the solver from known coefficients, fitted from a start off the truth: the values come
// back within a small fraction of their sigmas, chi^2 ~ 0, no warning. The same for the
// single-scattering rough top over a Lambert substrate (its refusal predated the projection).
const char* kRoughSlab = R"({"lamina_material": 1, "roughness": 0.3, "interface_model": "energy_conserving",
  "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": [0.3, 1.0, 2.0], "sigma_s": [8.0, 12.0, 15.0], "g": 0.8}],
  "below": {"ior": 1.0}})";
const char* kRoughSingleScattering = R"({"lamina_material": 1, "roughness": 0.3, "interface_model": "single_scattering",
  "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": [0.3, 1.0, 2.0], "sigma_s": [8.0, 12.0, 15.0], "g": 0.8}],
  "below": {"lambert": [0.6, 0.5, 0.4]}})";

void expect_rough_round_trip(const char* json, bool transmits) {
  const StackTemplate t = parse_stack_template_json(json, "rough");
  ASSERT_TRUE(t.stack.rough_top());
  std::vector<FitMeasurement> d;  // R (and T) at 0 and 45 degrees and under diffuse light
  for (int c = 0; c < kChannels; ++c)
    for (int incidence = 0; incidence < 3; ++incidence)
      for (FitQuantity q : {FitQuantity::kR, FitQuantity::kT}) {
        if (q == FitQuantity::kT && !transmits) continue;
        FitMeasurement m;
        m.quantity = q;
        m.channel = c;
        m.diffuse = incidence == 2;
        m.theta_i_deg = incidence == 1 ? 45.0 : 0.0;
        m.sigma = 1e-3;
        d.push_back(m);
      }
  simulate(t, &d, 0);
  StackTemplate start = t;
  start.layers[0].components[0].sigma_a = Spectrum(1.5);
  start.layers[0].components[0].sigma_s = Spectrum(20.0);
  mix_layer(start.layers[0], &start.stack.layers[0]);
  const std::vector<FitParameterSpec> specs = {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 50.0}};
  const FitResult r = fit_stack(start, specs, d, same_model());
  ASSERT_EQ(r.unknowns.size(), 6u);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  for (std::size_t k = 0; k < r.unknowns.size(); ++k) {
    const StackParameter p = parse_stack_parameter(t, specs[r.unknowns[k].parameter].path);
    const double truth_value = p.template_value(t)[r.unknowns[k].channel];
    EXPECT_NEAR(r.value[k], truth_value, 0.03 * r.sigma[k]) << r.unknowns[k].name;
    EXPECT_LT(std::abs(r.value[k] - truth_value), 0.01 * truth_value) << r.unknowns[k].name;
  }
  EXPECT_LT(r.chi2, 1e-4);
  std::printf("%d solutions (%d coarse)\n", r.evaluations, r.coarse_evaluations);
}

TEST(StackFit, EnergyConservingRoughSlabRoundTrip) { expect_rough_round_trip(kRoughSlab, true); }

TEST(StackFit, SingleScatteringRoughTopRoundTrip) { expect_rough_round_trip(kRoughSingleScattering, false); }

// What would change the rough interfaces' projection at every evaluation is refused, one line
// naming the parameter: the roughness, and an index on a stack with a rough interface (the
// solver's directions depend on every index). Without a rough interface an index is fitted.
TEST(StackFit, RoughProjectionParametersAreOneLineErrors) {
  const StackTemplate t = parse_stack_template_json(kRoughSlab, "rough");
  std::vector<FitMeasurement> d = design(false, false);
  simulate(t, &d, 0);
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"roughness", 0.1, 0.5}}, d); }).find("roughness: a rough interface's roughness is not fitted"), 0u);
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"layers[0].ior", 1.3, 1.5}}, d); }).find("layers[0].ior: an index is not fitted on a stack with rough interfaces"), 0u);
  EXPECT_EQ(error_of([&] { fit_stack(t, {{"below.ior", 1.0, 1.5}}, d); }).find("below.ior: an index is not fitted"), 0u);
  const StackTemplate smooth = parse_stack_template_json(kSlab, "slab");
  EXPECT_TRUE(rough_projection_refusal(smooth, parse_stack_parameter(smooth, "layers[0].ior")).empty());
}

TEST(StackFit, BadMeasurementFilesAreOneLineErrors) {
  const std::string h = "quantity,channel,theta_i_deg,value,sigma\n";
  EXPECT_EQ(error_of([&] { parse_fit_measurements("quantity,channel,value,sigma\nR,r,0.1,0.01\n", "m.csv"); }),
            "m.csv: line 1: missing column 'theta_i_deg' (expected quantity,channel,theta_i_deg,value,sigma)");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0,nan,0.01\n", "m.csv"); }), "m.csv: line 2: value 'nan' is not a finite decimal number");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0,0.2,inf\n", "m.csv"); }), "m.csv: line 2: sigma 'inf' is not a finite decimal number");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0,0.2,0\n", "m.csv"); }), "m.csv: line 2: sigma '0' is not in [1e-12, 1e+06]");
  // A subnormal sigma (1/sigma^2 infinite) and a value whose squared residual overflows gave a
  // null chi^2 with exit status 0.
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0,0.2,1e-320\n", "m.csv"); }).find("m.csv: line 2: sigma '1e-320' is too small"), 0u);
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0,1e300,0.01\n", "m.csv"); }), "m.csv: line 2: value '1e300' is not in [-1e+06, 1e+06]");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0x1p3,0.2,0.01\n", "m.csv"); }), "m.csv: line 2: theta_i_deg '0x1p3' is not a finite decimal number");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,0,0.2\n", "m.csv"); }), "m.csv: line 2: 4 fields, the header has 5");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "A,r,0,0.2,0.1\n", "m.csv"); }).find("m.csv: line 2: quantity 'A'"), 0u);
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,x,0,0.2,0.1\n", "m.csv"); }), "m.csv: line 2: channel 'x' is not r, g or b");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "R,r,90,0.2,0.1\n", "m.csv"); }),
            "m.csv: line 2: theta_i_deg 90 is not in [0, 90) (or 'diffuse')");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h + "T_unscattered,r,diffuse,0.2,0.1\n", "m.csv"); }),
            "m.csv: line 2: T_unscattered is defined for collimated incidence only (diffuse incidence: R or T)");
  EXPECT_EQ(error_of([&] { parse_fit_measurements(h, "m.csv"); }), "m.csv: no measurements after the header");
  const std::vector<FitMeasurement> ok = parse_fit_measurements(h + "R, g, diffuse, 0.25, 0.01\nT_unscattered,b,30,0.1,0.002\n", "m.csv");
  ASSERT_EQ(ok.size(), 2u);
  EXPECT_TRUE(ok[0].diffuse);
  EXPECT_EQ(ok[0].channel, 1);
  EXPECT_EQ(ok[1].quantity, FitQuantity::kTUnscattered);
  EXPECT_EQ(ok[1].theta_i_deg, 30.0);
}

}  // namespace
}  // namespace lamina
