// materials/spectral/leaf_chromophores and the material file's "leaf" layers: the layer's
// absorption and scattering from PROSPECT-D's pieces, the plate-to-scattering relation against
// Stokes' pile, the key's one-line errors, energy and reciprocity of the layered leaf by
// adding-doubling, and the fitted leaf (scenes/spectral/leaf_layered.json) against PROSPECT-D
// at a handful of wavelengths (docs/spectral.md, "Layered leaf").
#include "materials/spectral/leaf_chromophores.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Each key reads its own member, and the layer's absorption is PROSPECT-D's K over the thickness.
TEST(LeafChromophores, AbsorptionIsProspectsOverTheThickness) {
  LeafContents one;
  for (const LeafContentKey& k : kLeafContentKeys) {
    LeafContents only;
    only.*k.member = 1.0;
    one.*k.member = 0.5 + (&k - kLeafContentKeys);
    EXPECT_GT(prospect_d_absorption(only, 450.0) + prospect_d_absorption(only, 1450.0) +
                  prospect_d_absorption(only, 2200.0), 0.0) << k.key;
  }
  EXPECT_EQ(std::size(kLeafContentKeys), 6u);
  LeafChromophores c;
  c.contents = one;
  for (double nm : {430.0, 680.0, 970.0, 1940.0, 2400.0})
    EXPECT_NEAR(c.absorption(nm, 0.08) * 0.08, prospect_d_absorption(one, nm), 1e-12 * prospect_d_absorption(one, nm));
  // A green leaf absorbs in the red band, hardly in the near infrared.
  ProspectParameters green;
  EXPECT_GT(prospect_d_absorption(green, 680.0), 20.0 * prospect_d_absorption(green, 850.0));
}

// m plates of diffuse transmittance t transmit 1 / (1 + m (1 - t)/t) (Stokes' pile without
// absorption); Kubelka-Munk's 1 / (1 + S d) with S d = (3/4) m plate_reduced_scattering_depth
// must give the same.
TEST(LeafChromophores, PlatesScatterAsStokesPile) {
  for (double nm : {450.0, 800.0, 1600.0, 2500.0}) {
    const PlateOptics one = plate(90.0, prospect_refractive_index(nm), 1.0, false);
    for (double m : {1.0, 2.5, 6.0}) {
      const double pile = stokes_pile(one, m + 1.0).transmittance;  // N - 1 = m plates
      EXPECT_NEAR(pile, 1.0 / (1.0 + 0.75 * m * plate_reduced_scattering_depth(nm)), 1e-12) << nm << " " << m;
    }
  }
  LeafChromophores c;
  c.plates = 2.0;
  c.g = 0.5;
  EXPECT_NEAR(c.scattering_coefficient(700.0, 0.1), 2.0 * plate_reduced_scattering_depth(700.0) / (0.1 * 0.5), 1e-12);
  c.scattering_power = 1.5;  // the power law is 1 at 1000 nm
  EXPECT_NEAR(c.scattering_coefficient(1000.0, 0.1), 2.0 * plate_reduced_scattering_depth(1000.0) / (0.1 * 0.5), 1e-12);
  EXPECT_NEAR(c.scattering_coefficient(500.0, 0.1),
              2.0 * plate_reduced_scattering_depth(500.0) * std::pow(2.0, 1.5) / (0.1 * 0.5), 1e-12);
  // The index falls from the blue to the short-wave infrared, and with it the scattering.
  EXPECT_GT(plate_reduced_scattering_depth(450.0), plate_reduced_scattering_depth(2400.0));
}

const char* kLeaf = R"({"lamina_material": 1, "layers": [
  {"name": "cuticle", "thickness": 0.003, "leaf": {}},
  {"name": "palisade", "thickness": 0.1,
   "leaf": {"chlorophyll": 24, "carotenoids": 5, "anthocyanins": 1, "water": 0.006, "dry_matter": 0.005, "plates": 0.4, "g": 0.9}},
  {"name": "spongy", "thickness": 0.12,
   "leaf": {"chlorophyll": 16, "carotenoids": 3, "brown": 0.2, "water": 0.005, "dry_matter": 0.004, "plates": 1.4,
            "scattering_power": -0.3, "g": 0.9}}]})";

TEST(LeafStack, ReadsLeafLayers) {
  const SpectralStack s = parse_spectral_stack_json(kLeaf, "leaf.json");
  ASSERT_EQ(s.leaves.size(), 3u);
  ASSERT_TRUE(s.leaves[0] && s.leaves[1] && s.leaves[2]);
  EXPECT_EQ(s.leaves[1]->contents.chlorophyll, 24.0);
  EXPECT_EQ(s.leaves[2]->contents.brown, 0.2);
  EXPECT_EQ(s.leaves[2]->plates, 1.4);
  EXPECT_EQ(s.leaves[0]->plates, 0.0);
  EXPECT_EQ(s.leaves[2]->scattering_power, -0.3);
  EXPECT_EQ(s.leaves[1]->scattering_power, 0.0);
  for (double nm : {450.0, 1450.0}) {
    const LayerStack at = stack_at_wavelength(s, nm);
    EXPECT_TRUE(at.grey());
    for (int i = 0; i < 3; ++i) EXPECT_EQ(at.layers[i].ior, prospect_refractive_index(nm));
    EXPECT_DOUBLE_EQ(at.layers[1].sigma_a[0], s.leaves[1]->absorption(nm, 0.1));
    EXPECT_DOUBLE_EQ(at.layers[2].sigma_s()[0], s.leaves[2]->scattering_coefficient(nm, 0.12));
    EXPECT_EQ(at.layers[0].sigma_a[0], 0.0);
    EXPECT_EQ(at.layers[2].lobes[0].g[0], 0.9);
  }
}

std::string leaf_error(const std::string& json) {
  try {
    parse_spectral_stack_json(json, "m.json");
  } catch (const StackFileError& e) {
    return e.what();
  }
  return "";
}

TEST(LeafStack, OneLineErrorsNameTheValue) {
  try {
    parse_stack_json(kLeaf, "leaf.json");
    FAIL() << "expected an error";
  } catch (const StackFileError& e) {
    EXPECT_EQ(std::string(e.what()), "leaf.json: layers[0].leaf: a layer given by leaf contents has spectral coefficients: "
                                     "it is read by `lamina render --spectral`, `lamina brdf --wavelengths` and `lamina fit --spectrum`");
  }
  const std::string head = R"({"lamina_material": 1, "layers": [{"thickness": 0.1, )";
  EXPECT_EQ(leaf_error(head + R"("leaf": {"chlorophyll": -1}}]})"),
            "m.json: layers[0].leaf.chlorophyll: must lie in [0, inf] (got -1)");
  EXPECT_EQ(leaf_error(head + R"("leaf": {"chlorophyl": 30}}]})").rfind("m.json: layers[0].leaf.chlorophyl: unknown key", 0), 0u);
  EXPECT_EQ(leaf_error(head + R"("leaf": {"plates": "many"}}]})"),
            "m.json: layers[0].leaf.plates: expected a number, got a string");
  EXPECT_EQ(leaf_error(head + R"("leaf": {"scattering_power": 5}}]})"),
            "m.json: layers[0].leaf.scattering_power: must lie in [-4, 4] (got 5)");
  EXPECT_EQ(leaf_error(head + R"("leaf": {"g": 1}}]})"),
            "m.json: layers[0].leaf.g: Henyey-Greenstein g must satisfy |g| < 1 (got 1)");
  EXPECT_EQ(leaf_error(head + R"("leaf": [1]}]})"), "m.json: layers[0].leaf: expected an object, got an array");
  EXPECT_EQ(leaf_error(head + R"("ior": 1.4, "leaf": {}}]})"),
            "m.json: layers[0].ior: a leaf layer's index is PROSPECT-D's at each wavelength: leave out ior");
  EXPECT_EQ(leaf_error(head + R"("leaf": {}, "sigma_a": 1}]})"),
            "m.json: layers[0]: give either leaf, or chromophores, or sigma_a, sigma_s and g, or components, not two of them");
  EXPECT_EQ(leaf_error(R"({"lamina_material": 1, "layers": [{"thickness": "inf", "leaf": {}}]})"),
            "m.json: layers[0].thickness: a leaf layer needs a finite thickness > 0 (its contents are per leaf area)");
  EXPECT_EQ(leaf_error(R"({"lamina_material": 1, "layers": [{"thickness": 0, "leaf": {}}]})"),
            "m.json: layers[0].thickness: a leaf layer needs a finite thickness > 0 (its contents are per leaf area)");
  EXPECT_EQ(leaf_error(head + R"("leaf": {}}, {"ior": 1.4, "thickness": 1, "sigma_a": [1, 2, 3], "sigma_s": 1, "g": 0}]})"),
            "m.json: layers[1]: in a stack with chromophore layers every other layer must be grey (one number per "
            "coefficient)");
  EXPECT_EQ(leaf_error(head + R"("leaf": {}}, {"ior": 1.4, "thickness": 1, "sigma_a": 1, "sigma_s": 1, "g": 0}]})"), "");
}

// Adding-doubling's totals account for all the light: without absorbers R + T = 1 at every
// wavelength (the solver conserves energy, so a leak in the leaf's stack would show), with them
// R + T + A = 1 with 0 < A < 1, more chlorophyll absorbs more, and under diffuse light the
// transmittance is the same from either side (reciprocity), which the adaxial and abaxial faces of
// the layered leaf must share though their reflectances differ.
TEST(LeafStack, ConservesEnergyAndTransmitsReciprocally) {
  const SpectralStack s = parse_spectral_stack_json(kLeaf, "leaf.json");
  SpectralStack clear = s;
  for (auto& leaf : clear.leaves) leaf->contents = LeafContents{};
  AddingDoublingSettings settings;
  settings.quadrature_points = 8;
  settings.only_channel = 0;
  const double mu = std::cos(20.0 * kPi / 180.0);
  for (double nm : {450.0, 550.0, 680.0, 800.0, 1450.0, 1940.0, 2300.0}) {
    const AddingDoublingTotals c = adding_doubling_totals(stack_at_wavelength(clear, nm), mu, settings);
    EXPECT_NEAR(c.R_specular[0] + c.R_diffuse[0] + c.T_ballistic[0] + c.T_diffuse[0], 1.0, 1e-6) << nm;
    EXPECT_NEAR(c.R_hemispherical[0] + c.T_hemispherical[0], 1.0, 1e-6) << nm;

    const LayerStack at = stack_at_wavelength(s, nm);
    const AddingDoublingTotals t = adding_doubling_totals(at, mu, settings);
    const double r = t.R_specular[0] + t.R_diffuse[0], tr = t.T_ballistic[0] + t.T_diffuse[0];
    EXPECT_NEAR(r + tr + t.absorbed[0], 1.0, 1e-12) << nm;
    EXPECT_GT(t.absorbed[0], 0.0) << nm;
    EXPECT_LT(r + tr, 1.0) << nm;
    const AddingDoublingTotals below = adding_doubling_totals(flipped(at), mu, settings);
    EXPECT_NEAR(below.T_hemispherical[0], t.T_hemispherical[0], 1e-6 + 1e-4 * t.T_hemispherical[0]) << nm;
    SpectralStack greener = s;
    greener.leaves[1]->contents.chlorophyll *= 2.0;
    if (nm < 700.0)
      EXPECT_GT(adding_doubling_totals(stack_at_wavelength(greener, nm), mu, settings).absorbed[0], t.absorbed[0]) << nm;
  }
}

// The fitted mature green leaf (scenes/spectral/leaf_layered.json, written by scripts/leaf_fit.py)
// against Lamina's PROSPECT-D of the same leaf (N 1.5, chlorophyll 40, carotenoids 8, water 0.01,
// dry matter 0.009) at ten wavelengths across 400-2500 nm, lit as PROSPECT assumes (isotropic
// light within 40 degrees: three Gauss-Legendre nodes in sin^2 theta, as the script). Tolerance:
// the fit report's largest deviation of this leaf over every nanometre (docs/leaf_fit.csv),
// rounded up to the next thousandth.
TEST(LayeredLeaf, FollowsProspectD) {
  constexpr double kTolerance = 0.008;
  const SpectralStack s = load_spectral_stack(std::string(LAMINA_SOURCE_DIR) + "/scenes/spectral/leaf_layered.json");
  ProspectParameters leaf;  // its defaults are the mature green leaf
  leaf.n = 1.5;
  AddingDoublingSettings settings;
  settings.quadrature_points = 8;
  settings.only_channel = 0;
  const double nodes[3] = {-0.7745966692414834, 0.0, 0.7745966692414834}, weights[3] = {5.0 / 18, 8.0 / 18, 5.0 / 18};
  const double u_max = std::pow(std::sin(40.0 * kPi / 180.0), 2.0);
  for (double nm : {450.0, 550.0, 680.0, 720.0, 1000.0, 1450.0, 1650.0, 1940.0, 2200.0, 2450.0}) {
    double r = 0.0, t = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double u = u_max * (nodes[k] + 1.0) / 2.0;
      const AddingDoublingTotals a = adding_doubling_totals(stack_at_wavelength(s, nm), std::sqrt(1.0 - u), settings);
      r += weights[k] * (a.R_specular[0] + a.R_diffuse[0]);
      t += weights[k] * (a.T_ballistic[0] + a.T_diffuse[0]);
    }
    const PlateOptics reference = prospect_d(leaf, nm);
    EXPECT_NEAR(r, reference.reflectance, kTolerance) << nm;
    EXPECT_NEAR(t, reference.transmittance, kTolerance) << nm;
  }
}

}  // namespace
}  // namespace lamina
