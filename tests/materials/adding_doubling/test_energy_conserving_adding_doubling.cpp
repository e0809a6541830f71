// Adding-doubling with energy-conserving rough interfaces (materials/adding_doubling/
// interface_fourier.h, project_microsurface; adding_doubling.cpp, 10. and 11.): the projection's
// own checks (energy, reciprocity, the first order against an independent sampler), and stacks
// with rough tops, rough inner and bottom interfaces against the walk (materials/brdf/brdf_table.h),
// which models the same microsurface (materials/interfaces/microsurface.h), totals and bins; a
// white furnace; the smooth limit.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/adding_doubling/interface_fourier.h"
#include "materials/base/sampling.h"  // Rng
#include "materials/brdf/brdf_table.h"
#include "materials/interfaces/microsurface.h"
#include "materials/stack/stack_file.h"
#include "tests/materials/adding_doubling/walk_and_solver.h"
#include "tests/materials/stack_fixtures.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

constexpr double kPiD = 3.14159265358979323846;

LayerStack energy_conserving(LayerStack s, double top_alpha, const std::string& name) {
  s.interface_model = InterfaceModel::EnergyConserving;
  s.top_roughness = top_alpha;
  s.name = name;
  return s;
}

LayerStack skin(double alpha) {
  return energy_conserving(load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json"), alpha,
                           "skin EC alpha " + std::to_string(alpha));
}

// Cells of 1/20 of mu^2 on each side (the incidences as weight-zero nodes above).
FourierDirections cells(int n) {
  FourierDirections d;
  for (int k = 0; k < n; ++k) {
    d.mu.push_back(std::sqrt((k + 0.5) / n));
    d.x_lo.push_back(static_cast<double>(k) / n);
    d.x_hi.push_back((k + 1.0) / n);
  }
  return d;
}

// Every column of the projection (both blocks, mode 0) sums to 1: the interface loses nothing.
// The energy step's correction, |1 - first order - higher orders| of a column before it, is
// the first order's quadrature error and the walks' error on the higher orders together: below
// 0.01 (measured 0.004-0.007; the walks' standard error on a share s of higher orders is
// sqrt(s (1 - s) / N) <= 0.004 at N = 16384).
TEST(EnergyConservingProjection, ColumnsSumToOne) {
  const FourierDirections above = cells(20), below = cells(20);
  for (double alpha : {0.1, 0.35, 1.0})
    for (double n_below : {1.4, 1.0 / 1.4}) {
      const InterfaceFourier f = project_microsurface(alpha, 1.0, n_below, above, below, 1);
      for (int j = 0; j < 20; ++j) {
        double from_above = 0.0, from_below = 0.0;
        for (int i = 0; i < 20; ++i) {
          from_above += f.Rt[0][i * 20 + j] + f.Td[0][i * 20 + j];
          from_below += f.Rb[0][i * 20 + j] + f.Tu[0][i * 20 + j];
        }
        EXPECT_NEAR(from_above, 1.0, 1e-12) << "alpha " << alpha << " column " << j;
        EXPECT_NEAR(from_below, 1.0, 1e-12) << "alpha " << alpha << " column " << j;
      }
      EXPECT_LT(f.largest_energy_correction, 0.01) << "alpha " << alpha << " n_below " << n_below;
    }
}

// The reflection from above by an estimator independent of the projection: the microsurface's
// own walks (MicrosurfaceDielectric::sample, weight 1), from a beam, against the beam's column.
TEST(EnergyConservingProjection, BeamReflectanceMatchesTheMicrosurfaceWalks) {
  const FourierDirections above = cells(20), below = cells(20);
  for (double alpha : {0.1, 0.5, 1.0})
    for (double theta : {0.0, 45.0, 75.0}) {
      const double mu = std::cos(theta * kPiD / 180.0);
      FourierDirections beam;
      beam.mu = {mu};
      beam.x_lo = beam.x_hi = {mu * mu};
      const BeamFourier b = project_microsurface_beams(alpha, 1.0, 1.4, beam, above, below, 1);
      double R = 0.0;
      for (int i = 0; i < 20; ++i) R += b.Rt[0][i];
      const MicrosurfaceDielectric surface{{alpha}, 1.0, 1.4};
      const glm::dvec3 wi{std::sqrt(1.0 - mu * mu), 0.0, mu};
      constexpr int n = 200000;
      int reflected = 0;
      for (int k = 0; k < n; ++k) {
        Rng rng(99, k);
        glm::dvec3 to;
        if (surface.sample(wi, rng, &to) && to.z > 0.0) ++reflected;
      }
      const double ref = static_cast<double>(reflected) / n, se = std::sqrt(ref * (1.0 - ref) / n);
      EXPECT_NEAR(R, ref, 4.3 * se + 1e-3) << "alpha " << alpha << " theta " << theta;
    }
}

// Reciprocity of the projected matrices: with uniform radiance over a cell, the power exchanged
// between two cells is the same read either way, W_j M_ij = W_i M_ji within a side, and
// n_a^2 W_j Td_ij = n_b^2 W_i Tu_ji across it (f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2). The
// first order is reciprocal up to its quadrature (the summed asymmetry, relative to the summed
// exchange, is 4 % for the narrow transmission at alpha 0.1 on 12 cells, below 1 % elsewhere),
// the higher orders by construction up to the energy step: the whole projection's asymmetry is
// at most the first order's plus 1e-3.
double asymmetry(const InterfaceFourier& f, int n, double na, double nb, int m) {
  double asym = 0.0, total = 0.0;
  const double w = 1.0 / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double pairs[3][2] = {{w * f.Rt[m][i * n + j], w * f.Rt[m][j * n + i]},
                                  {w * f.Rb[m][i * n + j], w * f.Rb[m][j * n + i]},
                                  {na * na * w * f.Td[m][i * n + j], nb * nb * w * f.Tu[m][j * n + i]}};
      for (const auto& p : pairs) {
        asym += std::abs(p[0] - p[1]);
        total += std::abs(p[0]) + std::abs(p[1]);
      }
    }
  return asym / total;
}

TEST(EnergyConservingProjection, Reciprocal) {
  const FourierDirections above = cells(12), below = cells(12);
  const double na = 1.0, nb = 1.4;
  for (double alpha : {0.1, 0.35, 1.0}) {
    const InterfaceFourier f = project_microsurface(alpha, na, nb, above, below, 3);
    const InterfaceFourier first = project_interface(alpha, na, nb, microsurface_single_eval, above, below, 3);
    for (int m = 0; m < 3; ++m)
      EXPECT_LE(asymmetry(f, 12, na, nb, m), asymmetry(first, 12, na, nb, m) + 1e-3) << "alpha " << alpha << " mode " << m;
  }
}

// The totals against the walk's, split as the walk splits them (R_specular and T_ballistic the
// unscattered light, the rest diffuse), within kWalkZ standard errors of the walk plus the
// solver's discretisation estimate (order 16 against 8). A part that few walks reach (the
// unscattered light that comes back from an inner rough interface: ~1e-5) may have no walk at
// all and a standard error of 0: such a part is known to 3 / samples (a Poisson count of 0
// bounds the mean by 3 at 95 %), which is added.
constexpr double kWalkZ = 4.3;
void expect_totals_match_walk(const LayerStack& s, double theta_deg, std::uint64_t samples) {
  const test::WalkAndSolver both = test::walk_and_solver(s, theta_deg, samples);
  const EnergyTotals& m = both.walk.totals;
  const AddingDoublingEstimate& ad = both.solver;
  for (int c = 0; c < kChannels; ++c) {
    const double unresolved = m.unresolved.value[c];
    auto near = [&](double a, double e, const Estimate& x, const char* what) {
      EXPECT_NEAR(a, x.value[c], kWalkZ * x.stderr_[c] + e + unresolved + 3.0 / samples)
          << s.name << " theta " << theta_deg << " channel " << c << " " << what << " stderr " << x.stderr_[c]
          << " solver error " << e;
    };
    near(ad.totals.R_specular[c], ad.error.R_specular[c], m.R_specular, "R_specular");
    near(ad.totals.R_diffuse[c], ad.error.R_diffuse[c], m.R_diffuse, "R_diffuse");
    near(ad.totals.T_ballistic[c], ad.error.T_ballistic[c], m.T_ballistic, "T_ballistic");
    near(ad.totals.T_diffuse[c], ad.error.T_diffuse[c], m.T_diffuse, "T_diffuse");
    near(ad.totals.absorbed[c], ad.error.absorbed[c], m.absorbed, "absorbed");
  }
}

TEST(EnergyConservingAddingDoublingVsWalk, SkinRoughTop) {
  for (double alpha : {0.1, 0.35, 1.0})
    for (double theta : {0.0, 45.0, 75.0}) expect_totals_match_walk(skin(alpha), theta, 40000);
}

// A rough interface between two layers of different index, smooth top.
LayerStack inner_rough(double alpha) {
  LayerStack s = test::skin_like_stack();
  s.layers[1].ior = 1.55;
  s.layers[0].bottom_roughness = alpha;
  return energy_conserving(s, 0.0, "inner rough alpha " + std::to_string(alpha));
}

TEST(EnergyConservingAddingDoublingVsWalk, InnerRoughInterface) {
  for (double alpha : {0.1, 0.6})
    for (double theta : {0.0, 45.0, 75.0}) expect_totals_match_walk(inner_rough(alpha), theta, 40000);
}

// A transmitting slab (a leaf-like cuticle: rough top and bottom) seen from both sides.
LayerStack leaf(double alpha) {
  LayerStack s = test::one_layer(1.45, 0.2, Spectrum(0.5, 0.1, 2.0), Spectrum(10.0), Spectrum(0.5));
  s.layers[0].bottom_roughness = 0.5 * alpha;
  return energy_conserving(s, alpha, "leaf alpha " + std::to_string(alpha));
}

TEST(EnergyConservingAddingDoublingVsWalk, TransmittingStackFromBothSides) {
  for (double alpha : {0.2, 1.0})
    for (double theta : {0.0, 45.0, 75.0}) {
      expect_totals_match_walk(leaf(alpha), theta, 40000);
      LayerStack back = flipped(leaf(alpha));
      back.name += " from below";
      expect_totals_match_walk(back, theta, 40000);
    }
}

// The bins against the walk's (which hold the light that scattered at least once, as
// adding-doubling's do with bins_hold_unscattered false): each within 4.5 of the walk's standard
// errors and a chi-square consistent with their count, green channel.
void expect_bins_match_walk(const LayerStack& s, double theta_deg, int K, int M, std::uint64_t samples) {
  BrdfOptions o;
  o.theta_i_deg = theta_deg;
  o.samples = samples;
  o.bins_theta = K;
  o.bins_phi = M;
  const BrdfTable ad = brdf_table_adding_doubling(s, o);
  const BrdfTable mc = brdf_table_monte_carlo(s, o);
  constexpr int c = 1;
  test::BinAgreement agreement;
  for (int side = 0; side < (s.transmits() ? 2 : 1); ++side)
    for (int k = 0; k < K; ++k)
      for (int m = 0; m < M; ++m) {
        const int b = ad.bin_index(static_cast<BrdfSide>(side), k, m);
        ASSERT_GT(mc.stderr_[b][c], 0.0);
        agreement.add(ad, mc, b, c, s.name + " side " + std::to_string(side) + " k " + std::to_string(k) + " m " + std::to_string(m));
      }
  agreement.expect_consistent(s.name);
}

TEST(EnergyConservingAddingDoublingBins, SkinAt60Degrees) { expect_bins_match_walk(skin(0.35), 60.0, 4, 6, 200000); }
TEST(EnergyConservingAddingDoublingBins, InnerRoughAt30Degrees) { expect_bins_match_walk(inner_rough(0.3), 30.0, 4, 6, 200000); }
TEST(EnergyConservingAddingDoublingBins, LeafFromBelow) {
  LayerStack back = flipped(leaf(0.4));
  back.name = "leaf from below";
  expect_bins_match_walk(back, 45.0, 3, 4, 200000);
}

// A white furnace: a stack that neither absorbs nor loses light at its interfaces, over a white
// Lambert substrate, reflects everything. Layers (renormalised phase functions), the Lambert
// substrate and the projected interfaces (each column made to sum to 1) conserve power exactly,
// so the solver's total reflectance is 1 up to rounding (measured 1e-13): 1e-9 here, at alpha
// 0.1 ... 1, lit from 0, 45 and 75 degrees and by diffuse light, with a rough top and a rough
// inner interface.
TEST(EnergyConservingAddingDoubling, WhiteFurnace) {
  for (double alpha : {0.1, 0.3, 0.6, 1.0}) {
    LayerStack s;
    s.layers.push_back(make_layer("a", 1.4, 0.2, Spectrum(0.0), Spectrum(10.0), Spectrum(0.7)));
    s.layers.push_back(make_layer("b", 1.6, 0.5, Spectrum(0.0), Spectrum(5.0), Spectrum(0.0)));
    s.layers[0].bottom_roughness = alpha;
    s.below.kind = Below::Kind::Lambert;
    s.below.albedo = Spectrum(1.0);
    s = energy_conserving(s, alpha, "white furnace");
    ASSERT_EQ(validate_stack(s), "");
    for (double theta : {0.0, 45.0, 75.0}) {
      const AddingDoublingTotals t = adding_doubling_totals(s, std::cos(theta * kPiD / 180.0));
      for (int c = 0; c < kChannels; ++c) {
        EXPECT_NEAR(t.R_specular[c] + t.R_diffuse[c], 1.0, 1e-9) << "alpha " << alpha << " theta " << theta;
        EXPECT_NEAR(t.R_hemispherical[c], 1.0, 1e-9) << "alpha " << alpha;
      }
    }
  }
}

// Small alpha tends to the smooth solution: the collimated total reflectance and the unscattered
// part approach the smooth stack's as alpha falls, and at alpha 0.02 they are within 2e-3 (the
// microsurface's own distance from a mirror there is of the order of its lobe's spread over
// Fresnel's slope: ~1e-3).
TEST(EnergyConservingAddingDoubling, SmallAlphaTendsToTheSmoothSolution) {
  const LayerStack smooth = skin(0.0);
  for (double theta : {0.0, 60.0}) {
    const double mu = std::cos(theta * kPiD / 180.0);
    const AddingDoublingTotals s = adding_doubling_totals(smooth, mu);
    double previous = 1.0;
    for (double alpha : {0.2, 0.1, 0.05, 0.02}) {
      const AddingDoublingTotals r = adding_doubling_totals(skin(alpha), mu);
      double distance = 0.0;
      for (int c = 0; c < kChannels; ++c) {
        distance = std::max(distance, std::abs((r.R_specular[c] + r.R_diffuse[c]) - (s.R_specular[c] + s.R_diffuse[c])));
        distance = std::max(distance, std::abs(r.R_specular[c] - s.R_specular[c]));
      }
      EXPECT_LT(distance, previous) << "theta " << theta << " alpha " << alpha;
      previous = distance;
    }
    EXPECT_LT(previous, 2e-3) << "theta " << theta;
  }
}

}  // namespace
}  // namespace lamina
