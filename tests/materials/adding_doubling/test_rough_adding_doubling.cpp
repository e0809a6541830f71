// Adding-doubling with a rough top interface (materials/adding_doubling/interface_fourier.h): the
// projection's own checks (conservation against the interface's albedo by an independent
// quadrature, the smooth limit, reciprocity), and the stack's totals and bins against the walk's
// (materials/brdf/brdf_table.h), which models the same single-scattering GGX top.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/adding_doubling/adding_doubling_test_hooks.h"
#include "tests/materials/adding_doubling/walk_and_solver.h"
#include "materials/adding_doubling/interface_fourier.h"
#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/brdf/brdf_table.h"
#include "materials/base/sampling.h"  // Rng
#include "materials/interfaces/microfacet.h"
#include "materials/stack/stack_file.h"
#include "tests/materials/stack_fixtures.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

constexpr double kPiD = 3.14159265358979323846;

AddingDoublingSettings order(int q) {
  AddingDoublingSettings s;
  s.quadrature_points = q;
  return s;
}

LayerStack rough(LayerStack s, double alpha, const std::string& name) {
  s.top_roughness = alpha;
  s.interface_model = InterfaceModel::SingleScattering;  // this file tests the single-scattering top
  s.name = name;
  return s;
}

LayerStack skin(double alpha) {
  return rough(load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json"), alpha,
               "skin alpha " + std::to_string(alpha));
}

// The directional albedo of the rough dielectric from above, reflection and transmission, by an
// estimator independent of the projection: the interface's own sampler (visible normals, then
// Fresnel; weights in power), n samples, with standard errors.
void interface_albedo(double alpha, double n_above, double n_below, double mu_i, int n, double* R, double* T,
                      double* R_se, double* T_se) {
  const RoughDielectric d{{alpha}, n_above, n_below};
  const glm::dvec3 wi{std::sqrt(1.0 - mu_i * mu_i), 0.0, mu_i};
  double r = 0.0, r2 = 0.0, t = 0.0, t2 = 0.0;
  for (int k = 0; k < n; ++k) {
    Rng rng(17, k);
    const double u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
    const RoughDielectric::Sample smp = d.sample(wi, {u0, u1}, u2, true);
    const double w = smp.weight;
    if (smp.reflected) {
      r += w;
      r2 += w * w;
    } else {
      t += w;
      t2 += w * w;
    }
  }
  *R = r / n;
  *T = t / n;
  *R_se = std::sqrt(std::max(0.0, r2 / n - *R * *R) / n);
  *T_se = std::sqrt(std::max(0.0, t2 / n - *T * *T) / n);
}

// Mode 0 of a beam's column sums to the interface's albedo: the outgoing cells tile the
// hemisphere, so the projection conserves what the BSDF conserves. Here at alpha 0.02 to 1 and
// three incidences (normal: the narrow transmitted lobe at the pole; 75 degrees: the cut where
// refraction stops), within 4.3 standard errors of the sampler's estimate (Bonferroni over the
// 30 comparisons).
TEST(RoughInterfaceProjection, ColumnSumsAreTheInterfaceAlbedo) {
  FourierDirections above, below;
  // One cell per 1/20 of mu^2 on each side, the incidences as weight-zero nodes.
  for (int k = 0; k < 20; ++k) {
    above.mu.push_back(std::sqrt((k + 0.5) / 20.0));
    above.x_lo.push_back(k / 20.0);
    above.x_hi.push_back((k + 1) / 20.0);
  }
  below = above;
  const std::vector<double> incidences{1.0, std::cos(45.0 * kPiD / 180.0), std::cos(75.0 * kPiD / 180.0)};
  for (double mu : incidences) {
    above.mu.push_back(mu);
    above.x_lo.push_back(mu * mu);
    above.x_hi.push_back(mu * mu);
  }
  for (double alpha : {0.02, 0.1, 0.35, 0.6, 1.0}) {
    const InterfaceFourier f = project_interface(alpha, 1.0, 1.4, single_scattering_ggx_eval, above, below, 1);
    const int na = above.size(), nb = below.size();
    for (std::size_t q = 0; q < incidences.size(); ++q) {
      const int j = 20 + static_cast<int>(q);
      double R = 0.0, T = 0.0;
      for (int i = 0; i < na; ++i) R += f.Rt[0][i * na + j];
      for (int i = 0; i < nb; ++i) T += f.Td[0][i * na + j];
      double R_ref, T_ref, R_se, T_se;
      interface_albedo(alpha, 1.0, 1.4, incidences[q], 400000, &R_ref, &T_ref, &R_se, &T_se);
      EXPECT_NEAR(R, R_ref, 4.3 * R_se) << "alpha " << alpha << " mu " << incidences[q];
      EXPECT_NEAR(T, T_ref, 4.3 * T_se) << "alpha " << alpha << " mu " << incidences[q];
      // No power enters a weight-zero node.
      EXPECT_EQ(f.Rt[0][j * na + j], 0.0);
    }
  }
}

// The totals against the walk's: R_specular is the top's own (glossy) reflection in both, R_diffuse
// the light that entered and came back, absorbed the rest; within kWalkZ standard errors of the
// walk plus the solver's discretisation estimate (order 16 against 8). kWalkZ as in
// test_adding_doubling (Bonferroni over the comparisons here: 4 stacks and angles x 3 channels
// x 3 totals plus the glossy part).
constexpr double kWalkZ = 4.3;
void expect_rough_totals_match_walk(const LayerStack& s, double theta_deg, std::uint64_t samples) {
  const test::WalkAndSolver both = test::walk_and_solver(s, theta_deg, samples);
  const BrdfTable& mc = both.walk;
  const AddingDoublingEstimate& ad = both.solver;
  const EnergyTotals& m = mc.totals;
  for (int c = 0; c < kChannels; ++c) {
    const double unresolved = m.unresolved.value[c];
    auto near = [&](double a, double e, const Estimate& x, const char* what) {
      EXPECT_NEAR(a, x.value[c], kWalkZ * x.stderr_[c] + e + unresolved)
          << s.name << " theta " << theta_deg << " channel " << c << " " << what << " stderr " << x.stderr_[c];
    };
    near(ad.totals.R_specular[c], ad.error.R_specular[c], m.R_specular, "R_specular (glossy)");
    near(ad.totals.R_diffuse[c], ad.error.R_diffuse[c], m.R_diffuse, "R_diffuse");
    near(ad.totals.T_diffuse[c], ad.error.T_diffuse[c], m.T_diffuse, "T_diffuse");
    near(ad.totals.absorbed[c], ad.error.absorbed[c], m.absorbed, "absorbed");
    EXPECT_EQ(ad.totals.T_ballistic[c], 0.0);
  }
}

TEST(RoughAddingDoublingVsWalk, SkinAtThreeIncidences) {
  const LayerStack s = skin(0.35);
  for (double theta : {0.0, 45.0, 75.0}) expect_rough_totals_match_walk(s, theta, 100000);
}

TEST(RoughAddingDoublingVsWalk, VeryRoughSemiInfinite) {
  LayerStack s = test::one_layer(1.5, kInfiniteThickness, Spectrum(0.3, 1.0, 3.0), Spectrum(20.0), Spectrum(0.7));
  expect_rough_totals_match_walk(rough(s, 0.9, "semi-infinite alpha 0.9"), 30.0, 100000);
}

// The bins: the light that entered the stack (the walk's bins hold nothing else) within 4.5 of
// the walk's standard errors each and a chi-square consistent with their count (as
// test_adding_doubling's expect_bins_match_walk), green channel; their power is R_diffuse up to
// the cosine integration of the interpolated node radiances (kBinPower).
constexpr double kBinPower = 2e-3;
void expect_rough_bins_match_walk(const LayerStack& s, double theta_deg, int K, int M, std::uint64_t samples) {
  BrdfOptions o;
  o.theta_i_deg = theta_deg;
  o.samples = samples;
  o.bins_theta = K;
  o.bins_phi = M;
  AddingDoublingTotals totals;
  const BrdfTable ad = brdf_table_adding_doubling(s, o, order(16), &totals);
  const BrdfTable mc = brdf_table_monte_carlo(s, o);
  constexpr int c = 1;
  double chi2 = 0.0, power = 0.0;
  int dof = 0;
  for (int k = 0; k < K; ++k)
    for (int m = 0; m < M; ++m) {
      const int b = ad.bin_index(BrdfSide::Reflect, k, m);
      power += ad.value[b][c] * ad.projected_solid_angle(k);
      const double se = mc.stderr_[b][c];
      ASSERT_GT(se, 0.0);
      const double z = (ad.value[b][c] - mc.value[b][c]) / se;
      EXPECT_LT(std::abs(z), 4.5) << s.name << " k " << k << " m " << m << ": " << ad.value[b][c] << " vs "
                                  << mc.value[b][c] << " +- " << se;
      chi2 += z * z;
      ++dof;
    }
  EXPECT_GT(test::chi_square_p_value(chi2, dof), 1e-3) << s.name << " chi2 " << chi2 << " / " << dof;
  EXPECT_NEAR(power, totals.R_diffuse[c], kBinPower * totals.R_diffuse[c]) << s.name;
  EXPECT_EQ(totals.R_forward_peak[c], 0.0);
}

TEST(RoughAddingDoublingBins, SkinAt60Degrees) { expect_rough_bins_match_walk(skin(0.35), 60.0, 4, 6, 400000); }

TEST(RoughAddingDoublingBins, ForwardScatteringSlabOverLambert) {
  LayerStack s = test::one_layer(1.4, 0.3, Spectrum(0.3), Spectrum(10.0), Spectrum(0.6));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.5);
  expect_rough_bins_match_walk(rough(s, 0.2, "slab alpha 0.2 over Lambert"), 30.0, 4, 6, 400000);
}

// Small alpha tends to the smooth solution: the collimated totals' distance from the smooth
// stack's (total R and the top's own reflection, 0 and 60 degrees) falls with alpha and is below
// 2e-3 at alpha 0.02, the single-scattering interface's own hemispherical energy loss there for
// the light inside (measured with its sampler: 2.0e-3 from below, 8.4e-4 from above), which
// the smooth top does not have. The diffuse-
// incidence total converges more slowly (grazing directions, where masking stays strong, and the
// light trapped inside meets the top many times): it only has to fall with alpha.
TEST(RoughAddingDoubling, SmallAlphaTendsToTheSmoothSolution) {
  const LayerStack smooth = skin(0.0);
  for (double theta : {0.0, 60.0}) {
    const double mu = std::cos(theta * kPiD / 180.0);
    const AddingDoublingTotals s = adding_doubling_totals(smooth, mu);
    double previous = 1.0, previous_h = 1.0;
    for (double alpha : {0.2, 0.1, 0.05, 0.02}) {
      const AddingDoublingTotals r = adding_doubling_totals(skin(alpha), mu);
      double distance = 0.0, distance_h = 0.0;
      for (int c = 0; c < kChannels; ++c) {
        distance = std::max(distance, std::abs((r.R_specular[c] + r.R_diffuse[c]) - (s.R_specular[c] + s.R_diffuse[c])));
        distance = std::max(distance, std::abs(r.R_specular[c] - s.R_specular[c]));
        distance_h = std::max(distance_h, std::abs(r.R_hemispherical[c] - s.R_hemispherical[c]));
      }
      EXPECT_LT(distance, previous) << "theta " << theta << " alpha " << alpha;
      EXPECT_LT(distance_h, previous_h) << "theta " << theta << " alpha " << alpha;
      previous = distance;
      previous_h = distance_h;
    }
    EXPECT_LT(previous, 2e-3) << "theta " << theta;
  }
}

// Reciprocity of the light that entered: the power that incidence over cosine bin a sends into
// bin b, S_ab = int_a f(mu -> bin b) Omega_b mu dmu (one azimuth bin: mode 0; the incidence
// integral by 4 Gauss-Legendre points per bin), equals S_ba. The solver is reciprocal only up to
// its discretisation (the rough projection's cells add theirs to the layers'), so: the summed
// asymmetry over the pairs at least halves from 8 to 16 and from 16 to 32 points (measured: by
// 3-5x), and at 16 points it is within the summed discretisation error of the entries
// themselves: |S(16) - S(32)| of both entries of each pair, times r/(r - 1) <= 2 for an error
// that falls by r >= 2 per doubling (Richardson), as the halving just checked.
std::vector<double> bin_transfer(const LayerStack& s, int points, int K, int c) {
  constexpr int kQ = 4;
  BrdfOptions o;
  o.bins_theta = K;
  o.bins_phi = 1;
  std::vector<double> theta, weight;
  for (int k = 0; k < K; ++k) {
    double x[kQ], w[kQ];
    gauss_legendre(kQ, static_cast<double>(k) / K, (k + 1.0) / K, x, w);
    for (int q = 0; q < kQ; ++q) {
      theta.push_back(std::acos(x[q]) * 180.0 / kPiD);
      weight.push_back(w[q] * x[q]);
    }
  }
  AddingDoublingSettings st = order(points);
  st.single_scattering_bins = false;
  st.only_channel = c;
  const std::vector<BrdfTable> t = brdf_tables_adding_doubling(s, o, theta, st);
  std::vector<double> S(K * K, 0.0);
  for (int a = 0; a < K; ++a)
    for (int q = 0; q < kQ; ++q)
      for (int b = 0; b < K; ++b) {
        const BrdfTable& table = t[a * kQ + q];
        S[a * K + b] += weight[a * kQ + q] * table.value[table.bin_index(BrdfSide::Reflect, b, 0)][c] * table.projected_solid_angle(b);
      }
  return S;
}

TEST(RoughAddingDoubling, Reciprocal) {
  constexpr int K = 5, c = 1;
  for (double alpha : {0.1, 0.35, 1.0}) {
    const LayerStack s = skin(alpha);
    const std::vector<double> s8 = bin_transfer(s, 8, K, c), s16 = bin_transfer(s, 16, K, c), s32 = bin_transfer(s, 32, K, c);
    double asym[3] = {0.0, 0.0, 0.0}, discretisation = 0.0;
    for (int a = 0; a < K; ++a)
      for (int b = a + 1; b < K; ++b) {
        const int ab = a * K + b, ba = b * K + a;
        int level = 0;
        for (const std::vector<double>* S : {&s8, &s16, &s32}) asym[level++] += std::abs((*S)[ab] - (*S)[ba]);
        discretisation += std::abs(s16[ab] - s32[ab]) + std::abs(s16[ba] - s32[ba]);
      }
    EXPECT_LT(asym[1], 0.5 * asym[0]) << "alpha " << alpha;
    EXPECT_LT(asym[2], 0.5 * asym[1]) << "alpha " << alpha;
    EXPECT_LE(asym[1], 2.0 * discretisation) << "alpha " << alpha;
  }
}

// Under a rough top the layers are doubled on the real nodes alone (adding_doubling.cpp,
// DroppedNodes), and the bottom layers of one medium over a Lambert substrate added on that
// medium's nodes alone (add_bottom_run): the same numbers, bit for bit, as doubling and adding
// them on every node (the test hook's plain path). Cases where the dropped nodes matter to the doubling: an
// index-matched layer lit at 89.9 degrees (the incidence is the smallest cosine there, which
// sets the starting thickness), a layer thick enough that its transmission flushes to 0 (the
// incidence's diagonal keeps the doubling going), optical depths beyond the doubles (doubled to
// convergence: the plain path), both rough models, a transmitting
// energy-conserving leaf, a rough inner interface; totals at four incidences and 3 orders, and a
// table at three incidences.
TEST(RoughAddingDoubling, LayersOnTheRealNodesAloneGiveTheSameNumbers) {
  auto plain = [](auto solve) {  // the plain path, behind the solver's test hook
    adding_doubling_test_hooks::double_on_every_node = true;
    auto result = solve();
    adding_doubling_test_hooks::double_on_every_node = false;
    return result;
  };
  auto file = [](const char* f) { return load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/" + f); };
  LayerStack matched;
  matched.top_roughness = 0.3;
  matched.layers.push_back(make_layer("matched", 1.0, 0.5, Spectrum(0.5, 1.0, 2.0), Spectrum(5.0), Spectrum(0.7)));
  matched.layers.push_back(make_layer("slab", 1.4, 0.5, Spectrum(0.1), Spectrum(10.0), Spectrum(0.5)));
  LayerStack deep = matched;
  deep.layers[1].thickness = 400.0;  // tau 4000: exp(-tau / mu) below 1e-200 at every node
  LayerStack overflow = matched;  // an optical depth beyond the doubles: doubled to convergence
  overflow.layers[1].thickness = 1e308;
  overflow.layers[0].thickness = 1e308;
  LayerStack conserving = file("skin_oily.json");
  conserving.interface_model = InterfaceModel::EnergyConserving;
  LayerStack inner = conserving;
  inner.layers[0].bottom_roughness = 0.3;
  LayerStack matched_ec = matched;
  matched_ec.interface_model = InterfaceModel::EnergyConserving;
  int compared = 0;
  for (const LayerStack& s : {skin(0.35), matched, deep, overflow, matched_ec, conserving, inner, file("leaf_rough.json")}) {
    for (int q : {4, 8, 16}) {
      for (double deg : {0.0, 45.0, 80.0, 89.9}) {
        const double mu = std::cos(deg * kPiD / 180.0);
        const AddingDoublingTotals a = adding_doubling_totals(s, mu, order(q));
        const AddingDoublingTotals b = plain([&] { return adding_doubling_totals(s, mu, order(q)); });
        using T = AddingDoublingTotals;
        for (Spectrum T::*field : {&T::R_specular, &T::R_diffuse, &T::T_ballistic, &T::T_diffuse, &T::absorbed,
                                   &T::R_hemispherical, &T::T_hemispherical, &T::absorbed_hemispherical,
                                   &T::R_hemispherical_glossy})
          for (int c = 0; c < 3; ++c) {
            EXPECT_EQ((a.*field)[c], (b.*field)[c]) << s.name << " " << q << " " << deg;
            ++compared;
          }
        EXPECT_EQ(a.doublings, b.doublings) << s.name << " " << q << " " << deg;
      }
    }
    BrdfOptions o;
    o.bins_theta = 4;
    o.bins_phi = 6;
    const std::vector<BrdfTable> a = brdf_tables_adding_doubling(s, o, {0.0, 50.0, 85.0});
    const std::vector<BrdfTable> b = plain([&] { return brdf_tables_adding_doubling(s, o, {0.0, 50.0, 85.0}); });
    for (std::size_t t = 0; t < a.size(); ++t)
      for (std::size_t k = 0; k < a[t].value.size(); ++k)
        for (int c = 0; c < 3; ++c) EXPECT_EQ(a[t].value[k][c], b[t].value[k][c]) << s.name << " table " << t << " bin " << k;
  }
  EXPECT_EQ(compared, 8 * 3 * 4 * 9 * 3);
}


}  // namespace
}  // namespace lamina
