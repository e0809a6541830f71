// Adding-doubling with diffuse interfaces (materials/interfaces/diffuse_interface.h;
// adding_doubling.cpp, 13.): energy conservation, reciprocity, and PROSPECT's plate, which a
// one-layer stack with a diffuse top and bottom, PROSPECT's index and absorption and no
// scattering must reproduce.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/spectral/prospect.h"
#include "materials/stack/stack_file.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

constexpr double kPiD = 3.14159265358979323846;

// A scattering, non-absorbing three-layer stack with diffuse interfaces at the top, between the
// first two layers (index step 1.5 | 1.33) and at the bottom; `above` and `below` the outside
// indices.
LayerStack diffuse_stack(double above, double below, double sigma_a = 0.0) {
  LayerStack s = test::stack_of({make_layer("cuticle", 1.5, 0.02, Spectrum(sigma_a), Spectrum(5.0), Spectrum(0.3)),
                                 make_layer("cells", 1.33, 0.2, Spectrum(sigma_a), Spectrum(30.0), Spectrum(0.8)),
                                 make_layer("lower", 1.33, 0.1, Spectrum(sigma_a), Spectrum(10.0), Spectrum(0.0))},
                                above, below);
  s.top_diffuse = true;
  s.layers[0].bottom_diffuse = true;
  s.layers[2].bottom_diffuse = true;
  EXPECT_EQ(validate_stack(s), "");
  EXPECT_TRUE(s.diffuse_interface(0) && s.diffuse_interface(1) && s.diffuse_interface(3));
  return s;
}

// Without absorption nothing is lost, whatever the interfaces do: R + T = 1 for collimated light
// at any angle and for diffuse light, to rounding (the interface's columns sum to 1 on the
// nodes; measured 1e-14). Lit from air and from a denser medium above (where the top reflects
// diffusely), and over a white Lambert substrate (R = 1).
TEST(DiffuseAddingDoubling, ConservesEnergy) {
  for (const double above : {1.0, 1.7}) {
    const LayerStack s = diffuse_stack(above, 1.0);
    for (double theta : {0.0, 40.0, 80.0}) {
      const AddingDoublingTotals t = adding_doubling_totals(s, std::cos(theta * kPiD / 180.0));
      for (int c = 0; c < kChannels; ++c) {
        EXPECT_NEAR(t.R_specular[c] + t.R_diffuse[c] + t.T_ballistic[c] + t.T_diffuse[c], 1.0, 1e-10)
            << "above " << above << " theta " << theta;
        EXPECT_NEAR(t.absorbed[c], 0.0, 1e-10);
        EXPECT_NEAR(t.R_hemispherical[c] + t.T_hemispherical[c], 1.0, 1e-10);
        EXPECT_GT(t.T_diffuse[c], 0.1);
      }
    }
  }
  LayerStack white = diffuse_stack(1.0, 1.0);
  white.layers[2].bottom_diffuse = false;
  white.below.kind = Below::Kind::Lambert;
  white.below.albedo = Spectrum(1.0);
  for (double theta : {0.0, 60.0}) {
    const AddingDoublingTotals t = adding_doubling_totals(white, std::cos(theta * kPiD / 180.0));
    EXPECT_NEAR(t.R_specular[0] + t.R_diffuse[0], 1.0, 1e-10);
    EXPECT_NEAR(t.R_hemispherical[0], 1.0, 1e-10);
  }
}

// Reciprocity of the whole stack: f(i -> o) / n_o^2 = f(o -> i) / n_i^2 makes the diffuse-incidence
// transmittances from the two sides satisfy n_above^2 T_h(from above) = n_below^2 T_h(from below)
// (integrate f cos cos over both hemispheres). The solver holds it to rounding when every element
// does, so a wrong n^2 factor or a non-reciprocal diffuse transmission would show at once. With
// absorption, and different media above (air) and below (index 1.2).
TEST(DiffuseAddingDoubling, IsReciprocal) {
  const LayerStack s = diffuse_stack(1.0, 1.2, 0.8);
  const LayerStack f = flipped(s);
  ASSERT_TRUE(f.diffuse_interface(0) && f.diffuse_interface(2) && f.diffuse_interface(3));
  const AddingDoublingTotals down = adding_doubling_totals(s, 1.0), up = adding_doubling_totals(f, 1.0);
  EXPECT_NEAR(1.0 * down.T_hemispherical[0], 1.2 * 1.2 * up.T_hemispherical[0], 1e-12);
  EXPECT_GT(down.T_hemispherical[0], 0.05);
  // The stack is not symmetric: its two reflectances differ (the test is not trivially met).
  EXPECT_GT(std::abs(down.R_hemispherical[0] - up.R_hemispherical[0]), 0.01);
}

// PROSPECT's plate (Allen et al. 1969; materials/spectral/prospect.h): a leaf of N = 1 is one
// layer of PROSPECT's index n(lambda) and absorption optical depth K(lambda), no scattering, its
// two faces diffuse interfaces, lit by isotropic light within 40 degrees of the normal. The
// cone average of the solver's R(mu) and T(mu), int R(mu) mu dmu / int mu dmu over [cos 40, 1]
// (Gauss-Legendre, 24 points: R is smooth in mu there), against prospect_d.
struct ConeTotals {
  double r = 0.0, t = 0.0;
};
ConeTotals cone_average(const LayerStack& s, int quadrature_points) {
  constexpr int kPoints = 24;
  double mu[kPoints], w[kPoints];
  const double lo = std::cos(40.0 * kPiD / 180.0);
  gauss_legendre(kPoints, lo, 1.0, mu, w);
  AddingDoublingSettings settings;
  settings.quadrature_points = quadrature_points;
  settings.only_channel = 0;
  ConeTotals c;
  for (int i = 0; i < kPoints; ++i) {
    const AddingDoublingTotals t = adding_doubling_totals(s, mu[i], settings);
    const double weight = w[i] * mu[i] / (0.5 * (1.0 - lo * lo));
    c.r += weight * (t.R_specular[0] + t.R_diffuse[0]);
    c.t += weight * (t.T_ballistic[0] + t.T_diffuse[0]);
  }
  return c;
}

LayerStack one_plate(const ProspectParameters& p, double nm) {
  LayerStack s = test::stack_of({make_layer("plate", prospect_refractive_index(nm), 1.0,
                                            Spectrum(prospect_d_absorption(p, nm)), Spectrum(0.0), Spectrum(0.0))});
  s.top_diffuse = true;
  s.layers[0].bottom_diffuse = true;
  return s;
}

// The solver's only approximation here is its quadrature of the isotropic light inside the plate,
// sum_i W_i e^(-k / mu_i) for 2 E3(k) per pass. Measured, largest over the wavelengths below
// (k from 0.025 to 4.9): |solver - PROSPECT| 3.7e-6 in R and 4.5e-6 in T at the default 16
// points, 2.3e-8 and 2.8e-8 at 64. So the difference between 16 and 64 points is the error at 16
// within 1 %: the tolerance at 16 is that difference times 1.5 (plus 1e-9 for rounding), and
// at 64, 1e-7.
TEST(DiffuseAddingDoubling, OnePlateIsProspect) {
  ProspectParameters p;  // the default green leaf, as one plate
  p.n = 1.0;
  for (double nm : {400.0, 450.0, 550.0, 680.0, 750.0, 1000.0, 1450.0, 1940.0, 2500.0}) {
    const LayerStack s = one_plate(p, nm);
    const PlateOptics ref = prospect_d(p, nm);
    const ConeTotals c16 = cone_average(s, 16), c64 = cone_average(s, 64);
    const double tol_r = 1.5 * std::abs(c16.r - c64.r) + 1e-9, tol_t = 1.5 * std::abs(c16.t - c64.t) + 1e-9;
    EXPECT_NEAR(c16.r, ref.reflectance, tol_r) << nm << " nm";
    EXPECT_NEAR(c16.t, ref.transmittance, tol_t) << nm << " nm";
    EXPECT_NEAR(c64.r, ref.reflectance, 1e-7) << nm << " nm";
    EXPECT_NEAR(c64.t, ref.transmittance, 1e-7) << nm << " nm";
    std::printf("%6.0f nm  k %.4g  R %.6f T %.6f  dR16 %.2e dT16 %.2e  dR64 %.2e dT64 %.2e\n", nm,
                prospect_d_absorption(p, nm), ref.reflectance, ref.transmittance, c16.r - ref.reflectance,
                c16.t - ref.transmittance, c64.r - ref.reflectance, c64.t - ref.transmittance);
  }
}

// The same with specular reflection inside (the dense side reflecting as a mirror) would differ
// from PROSPECT by up to 0.01 (docs/adding_doubling.md): the diffuse stack above is not
// PROSPECT's by construction but because its interfaces are PROSPECT's. A smooth plate, for
// contrast, is far from it.
TEST(DiffuseAddingDoubling, SmoothPlateIsNotProspect) {
  ProspectParameters p;
  p.n = 1.0;
  LayerStack s = one_plate(p, 550.0);
  s.top_diffuse = false;
  s.layers[0].bottom_diffuse = false;
  EXPECT_GT(std::abs(cone_average(s, 16).t - prospect_d(p, 550.0).transmittance), 0.01);
}

// `lamina brdf --method adding-doubling`'s table on a diffuse stack: the bins' power is the
// diffuse totals (the light that scattered; the unscattered light, spread by the diffuse
// interfaces, is R_specular and T_ballistic as in the walk), every bin finite and >= 0.
TEST(DiffuseAddingDoubling, BrdfTable) {
  const LayerStack s = diffuse_stack(1.0, 1.0, 0.3);
  BrdfOptions o;
  o.theta_i_deg = 30.0;
  o.bins_theta = 6;
  o.bins_phi = 8;
  AddingDoublingTotals totals;
  const BrdfTable table = brdf_table_adding_doubling(s, o, {}, &totals);
  for (int c = 0; c < kChannels; ++c) {
    double r = 0.0, t = 0.0;
    for (int k = 0; k < o.bins_theta; ++k)
      for (int m = 0; m < o.bins_phi; ++m) {
        const double vr = table.value[table.bin_index(BrdfSide::Reflect, k, m)][c];
        const double vt = table.value[table.bin_index(BrdfSide::Transmit, k, m)][c];
        EXPECT_TRUE(std::isfinite(vr) && vr >= 0.0 && std::isfinite(vt) && vt >= 0.0);
        r += vr * table.projected_solid_angle(k);
        t += vt * table.projected_solid_angle(k);
      }
    EXPECT_NEAR(r, totals.R_diffuse[c], 2e-3) << c;
    EXPECT_NEAR(t, totals.T_diffuse[c], 2e-3) << c;
    EXPECT_NEAR(table.totals.R_diffuse.value[c], totals.R_diffuse[c], 1e-15);
    // Light that scattered leaves through the diffuse bottom with no azimuthal structure.
    const int k = 2;
    for (int m = 1; m < o.bins_phi; ++m)
      EXPECT_NEAR(table.value[table.bin_index(BrdfSide::Transmit, k, m)][c],
                  table.value[table.bin_index(BrdfSide::Transmit, k, 0)][c], 1e-9);
  }
}

}  // namespace
}  // namespace lamina
