// materials/adding_doubling/adding_doubling: published benchmarks, iadpython, energy conservation, the diffuse
// incidence against the cosine-weighted collimated results, convergence in quadrature order,
// and the Monte Carlo walk's totals (within 3 of its standard errors) on stacks the published
// cases do not cover (oblique incidence, several layers and indices, Lambert, composite lobes).
#include "materials/adding_doubling/adding_doubling.h"
#include "tests/materials/adding_doubling/walk_and_solver.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "materials/brdf/brdf_table.h"
#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/tables/layered_table.h"
#include "materials/stack/stack_file.h"
#include "tests/materials/stack_fixtures.h"
#include "tests/support/reference_csv.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::one_layer;
using test::stack_of;

AddingDoublingSettings order(int q) {
  AddingDoublingSettings s;
  s.quadrature_points = q;
  return s;
}

double total_R(const AddingDoublingTotals& t, int c) { return t.R_specular[c] + t.R_diffuse[c]; }
double total_T(const AddingDoublingTotals& t, int c) { return t.T_ballistic[c] + t.T_diffuse[c]; }

// MCML test case (Wang, Jacques and Zheng 1995, table 2; van de Hulst 1980): n = 1 everywhere,
// mu_a = 1/mm, mu_s = 9/mm, g = 0.75, 0.2 mm, normal incidence: diffuse reflectance 0.09739 and
// total transmittance 0.66096, published to 5 digits: the solution must round to them (5e-6).
TEST(AddingDoubling, McmlSlabMatchesVanDeHulst) {
  const LayerStack s = one_layer(1.0, 0.2, Spectrum(1.0), Spectrum(9.0), Spectrum(0.75));
  const AddingDoublingTotals t = adding_doubling_totals(s, 1.0, order(32));
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_NEAR(t.R_diffuse[c], 0.09739, 5e-6);
    EXPECT_NEAR(total_T(t, c), 0.66096, 5e-6);
    EXPECT_EQ(t.R_specular[c], 0.0);
    EXPECT_NEAR(t.T_ballistic[c], std::exp(-2.0), 1e-15);
  }
}

// Semi-infinite medium n = 1.5 under air, mu_a = 1, mu_s = 9, g = 0, normal incidence:
// Giovanelli (1955) total reflectance 0.2600 (specular 0.04 included; as quoted in the MCML
// paper). The solution converges to 0.259919 (16 to 48 nodes give the same six digits), and
// iadpython 0.5.3 gives 0.25994 and 0.25991 at 32 and 64 points: all three round to 0.2599,
// 8e-5 from the published value. The tolerance is therefore one unit of its last digit (1e-4),
// not half of one (docs/validation.md, "Adding-doubling").
TEST(AddingDoubling, SemiInfiniteMatchesGiovanelli) {
  const LayerStack s = one_layer(1.5, kInfiniteThickness, Spectrum(1.0), Spectrum(9.0), Spectrum(0.0));
  const AddingDoublingTotals t = adding_doubling_totals(s, 1.0);
  EXPECT_NEAR(total_R(t, 0), 0.2600, 1e-4);
  EXPECT_NEAR(t.R_specular[0], 0.04, 1e-15);
  EXPECT_EQ(total_T(t, 0), 0.0);
}

// tests/data/iad_reference.csv (scripts/iad_reference.py): single slabs, matched and mismatched,
// one between glass slides (clear layers of index 1.5, which also traps directions between two
// totally reflecting interfaces), normal and diffuse incidence, within 2e-4 in every total.
TEST(AddingDoubling, MatchesIadpython) {
  int cases = 0;
  for (const test::ReferenceRow& row : test::read_reference_csv(LAMINA_SOURCE_DIR, "tests/data/iad_reference.csv")) {
    const std::string& name = row.name;
    const std::vector<double>& v = row.v;
    ASSERT_EQ(v.size(), 12u) << row.line;
    const double n = v[0], n_above = v[1], n_below = v[2], sa = v[3], ss_ = v[4], g = v[5], d = v[6];
    std::vector<Layer> layers;
    const Spectrum zero(0.0);
    if (n_above != 1.0) layers.push_back(make_layer("slide", n_above, 1.0, zero, zero, zero));
    layers.push_back(make_layer("slab", n, d, Spectrum(sa), Spectrum(ss_), Spectrum(g)));
    if (n_below != 1.0) layers.push_back(make_layer("slide", n_below, 1.0, zero, zero, zero));
    const LayerStack s = stack_of(layers);
    const AddingDoublingTotals t = adding_doubling_totals(s, 1.0);
    EXPECT_NEAR(total_R(t, 0), v[8], 2e-4) << name << " ur1";
    EXPECT_NEAR(total_T(t, 0), v[9], 2e-4) << name << " ut1";
    EXPECT_NEAR(t.R_hemispherical[0], v[10], 2e-4) << name << " uru";
    EXPECT_NEAR(t.T_hemispherical[0], v[11], 2e-4) << name << " utu";
    ++cases;
  }
  EXPECT_EQ(cases, 8);
}

// Without absorption every photon leaves: R + T = 1 (to 1e-6) for collimated light at several
// angles and for diffuse light; over a white Lambert substrate or in a semi-infinite
// conservative medium R = 1. (A conservative semi-infinite layer's own column sums are 1 by
// construction, materials/adding_doubling/adding_doubling.cpp 6.; here it is added under a Fresnel interface.)
TEST(AddingDoubling, ConservesEnergyWithoutAbsorption) {
  const Spectrum zero(0.0);
  std::vector<LayerStack> stacks;
  stacks.push_back(one_layer(1.0, 0.5, zero, Spectrum(10.0), Spectrum(0.9)));
  stacks.push_back(one_layer(1.4, 0.3, zero, Spectrum(5.0, 20.0, 50.0), Spectrum(0.0, 0.5, -0.3), 1.0, 1.33));
  stacks.push_back(stack_of({make_layer("a", 1.5, 0.05, zero, Spectrum(30.0), Spectrum(0.8)),
                             make_layer("b", 1.33, 0.2, zero, Spectrum(8.0), Spectrum(-0.2)),
                             make_layer("c", 1.45, 0.1, zero, Spectrum(2.0), Spectrum(0.95))},
                            1.0, 1.2));
  LayerStack lambert = test::skin_like_stack();
  for (Layer& l : lambert.layers) l.sigma_a = zero;
  lambert.below.albedo = Spectrum(1.0);
  stacks.push_back(lambert);
  stacks.push_back(one_layer(1.33, kInfiniteThickness, zero, Spectrum(10.0), Spectrum(0.9)));
  for (const LayerStack& s : stacks)
    for (double mu : {1.0, 0.7, 0.2}) {
      const AddingDoublingTotals t = adding_doubling_totals(s, mu);
      for (int c = 0; c < kChannels; ++c) {
        EXPECT_NEAR(total_R(t, c) + total_T(t, c), 1.0, 1e-6) << s.layers[0].ior << " mu " << mu;
        EXPECT_NEAR(t.R_hemispherical[c] + t.T_hemispherical[c], 1.0, 1e-6) << s.layers[0].ior;
        EXPECT_GE(t.R_diffuse[c], 0.0);
        EXPECT_GE(t.T_diffuse[c], 0.0);
      }
    }
}

// Diffuse incidence is the cosine-weighted average of collimated incidence,
//   R_h = int_0^1 R(mu) 2 mu dmu,
// computed here from 24 separate collimated solutions (Gauss-Legendre in mu^2): an independent
// path through the solver (the incidence node's column instead of the quadrature's columns).
TEST(AddingDoubling, DiffuseIncidenceIsTheCosineWeightedAverage) {
  std::vector<LayerStack> stacks{one_layer(1.4, 0.3, Spectrum(0.5), Spectrum(5.0, 20.0, 50.0), Spectrum(0.8), 1.0, 1.33),
                                 test::skin_like_stack()};
  constexpr int n = 24;
  std::vector<double> x(n), w(n);
  gauss_legendre(n, 0.0, 1.0, x.data(), w.data());  // in x = mu^2: 2 mu dmu = dx
  for (const LayerStack& s : stacks) {
    const AddingDoublingTotals h = adding_doubling_totals(s, 1.0);
    Spectrum R(0.0), T(0.0);
    for (int i = 0; i < n; ++i) {
      const AddingDoublingTotals t = adding_doubling_totals(s, std::sqrt(x[i]));
      for (int c = 0; c < kChannels; ++c) {
        R[c] += w[i] * total_R(t, c);
        T[c] += w[i] * total_T(t, c);
      }
    }
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_NEAR(h.R_hemispherical[c], R[c], 1e-4) << s.name << " channel " << c;
      EXPECT_NEAR(h.T_hemispherical[c], T[c], 1e-4) << s.name << " channel " << c;
    }
  }
}

// Convergence in quadrature order on a mismatched, forward-peaked slab at oblique incidence: the
// error against 64 nodes falls with the order, and the error estimate of
// adding_doubling_with_error (the difference from half the order) bounds the actual error.
TEST(AddingDoubling, ConvergesInQuadratureOrder) {
  const LayerStack s = one_layer(1.4, 0.5, Spectrum(0.2), Spectrum(20.0), Spectrum(0.9), 1.0, 1.0);
  const double mu = std::cos(50.0 * 3.14159265358979323846 / 180.0);
  const AddingDoublingTotals ref = adding_doubling_totals(s, mu, order(64));
  double previous = 1.0;
  for (int q : {4, 8, 16}) {
    const AddingDoublingEstimate e = adding_doubling_with_error(s, mu, order(q));
    const double err = std::abs(e.totals.R_diffuse[0] - ref.R_diffuse[0]) + std::abs(e.totals.T_diffuse[0] - ref.T_diffuse[0]);
    EXPECT_LT(err, previous) << q;
    EXPECT_LE(std::abs(e.totals.R_diffuse[0] - ref.R_diffuse[0]), e.error.R_diffuse[0] + 1e-9) << q;
    EXPECT_LE(std::abs(e.totals.T_diffuse[0] - ref.T_diffuse[0]), e.error.T_diffuse[0] + 1e-9) << q;
    previous = err;
  }
  EXPECT_LT(previous, 1e-4);
}

// The Monte Carlo walk (materials/brdf/brdf_table.h) on stacks with what the published cases lack.
// R_diffuse, T_diffuse and absorbed agree within kWalkZ standard errors of the walk plus the
// solver's own discretisation error estimate; R_specular and T_ballistic are the same analytic
// zeroth order in both. kWalkZ: the tests below make 63 such comparisons (7 stacks and angles,
// 3 channels, 3 totals), so at 3 standard errors one random stream in six or so would fail one
// of them by chance (63 x 0.27 %; a new stream did, by 3.02 standard errors, and passed with 12
// other seeds). 4.3 keeps the chance of a false alarm over all of them below 1e-3 (Bonferroni:
// two-sided 1.6e-5 each); a bias of the walk of a few per cent still fails it.
constexpr double kWalkZ = 4.3;
void expect_matches_walk(const LayerStack& s, double theta_deg, std::uint64_t samples) {
  const test::WalkAndSolver both = test::walk_and_solver(s, theta_deg, samples);
  for (int c = 0; c < kChannels; ++c)
    test::expect_totals_agree(both, c, kWalkZ, s.name + " theta " + std::to_string(theta_deg) + " channel " + std::to_string(c));
}

TEST(AddingDoublingVsWalk, MatchedSlabForwardPeaked) {
  LayerStack s = one_layer(1.0, 0.3, Spectrum(0.3, 1.0, 3.0), Spectrum(10.0), Spectrum(0.9));
  s.name = "matched g 0.9";
  expect_matches_walk(s, 30.0, 100000);
}

TEST(AddingDoublingVsWalk, MismatchedSlabOverWater) {
  LayerStack s = one_layer(1.4, 0.2, Spectrum(0.5), Spectrum(5.0, 15.0, 40.0), Spectrum(0.8, 0.0, -0.3), 1.0, 1.33);
  s.name = "n 1.4 over 1.33";
  expect_matches_walk(s, 55.0, 100000);
}

TEST(AddingDoublingVsWalk, ThreeLayersThreeIndices) {
  LayerStack s = stack_of({make_layer("a", 1.5, 0.05, Spectrum(1.0), Spectrum(30.0), Spectrum(0.8)),
                           make_layer("b", 1.33, 0.2, Spectrum(0.2, 0.5, 2.0), Spectrum(8.0), Spectrum(-0.2)),
                           make_layer("c", 1.45, 0.1, Spectrum(0.5), Spectrum(4.0), Spectrum(0.95))},
                          1.0, 1.2);
  s.name = "three layers";
  expect_matches_walk(s, 20.0, 100000);
}

TEST(AddingDoublingVsWalk, LambertSubstrate) {
  const LayerStack s = test::skin_like_stack();
  expect_matches_walk(s, 0.0, 50000);
  expect_matches_walk(s, 70.0, 50000);
}

TEST(AddingDoublingVsWalk, SemiInfiniteForwardPeaked) {
  LayerStack s = one_layer(1.33, kInfiniteThickness, Spectrum(0.5, 1.0, 2.0), Spectrum(30.0), Spectrum(0.9));
  s.name = "semi-infinite g 0.9";
  expect_matches_walk(s, 40.0, 50000);
}

// The skin preset: two composite layers (two HG lobes each, the mixture of stack.h) over Lambert.
TEST(AddingDoublingVsWalk, CompositeSkin) {
  const LayerStack s = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  expect_matches_walk(s, 45.0, 50000);
}

// The BRDF/BTDF bins (Fourier modes m >= 0) against the walk's bins: no bin further than 4.5
// standard errors (Bonferroni over ~100 bins: P(|z| > 4.5) = 7e-6 each) and the chi-square of
// all bins' z-scores consistent with their count (p > 1e-3). Green channel (the walk's bins of
// the three channels share photons). The bins' power equals the diffuse totals.
void expect_bins_match_walk(const LayerStack& s, double theta_deg, int K, int M, std::uint64_t samples, int points) {
  BrdfOptions o;
  o.theta_i_deg = theta_deg;
  o.samples = samples;
  o.bins_theta = K;
  o.bins_phi = M;
  AddingDoublingTotals totals;
  const BrdfTable ad = brdf_table_adding_doubling(s, o, order(points), &totals);
  const BrdfTable mc = brdf_table_monte_carlo(s, o);
  constexpr int c = 1;
  test::BinAgreement agreement;
  double power[2] = {0.0, 0.0};
  for (int side = 0; side < 2; ++side)
    for (int k = 0; k < K; ++k)
      for (int m = 0; m < M; ++m) {
        const int b = ad.bin_index(static_cast<BrdfSide>(side), k, m);
        power[side] += ad.value[b][c] * ad.projected_solid_angle(k);
        EXPECT_EQ(ad.stderr_[b][c], 0.0);
        if (mc.stderr_[b][c] == 0.0) {
          EXPECT_NEAR(ad.value[b][c], 0.0, 1e-12) << s.name << " side " << side << " k " << k << " m " << m;
          continue;
        }
        agreement.add(ad, mc, b, c, s.name + " side " + std::to_string(side) + " k " + std::to_string(k) + " m " + std::to_string(m));
      }
  agreement.expect_consistent(s.name);
  EXPECT_NEAR(power[0], totals.R_diffuse[c], 1e-9) << s.name;
  EXPECT_NEAR(power[1], totals.T_diffuse[c], 1e-9) << s.name;
  EXPECT_NEAR(ad.totals.R_diffuse.value[c], totals.R_diffuse[c], 0.0);
}

TEST(AddingDoublingBins, MismatchedSlab) {
  LayerStack s = one_layer(1.4, 0.3, Spectrum(0.3), Spectrum(10.0), Spectrum(0.5));
  s.name = "n 1.4 g 0.5";
  expect_bins_match_walk(s, 40.0, 4, 6, 1000000, 16);
}

TEST(AddingDoublingBins, LeafTwoLayersComposite) {
  LayerStack s = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/leaf.json");
  expect_bins_match_walk(s, 40.0, 4, 6, 400000, 16);
}

TEST(AddingDoublingBins, SkinOverLambert) {
  const LayerStack s = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  expect_bins_match_walk(s, 60.0, 3, 4, 100000, 16);
}

// Forward-peaked (g = 0.9) transmission: delta-M at 16 points puts f = 0.9^16 = 19% of each
// scattering into the forward delta, whose power lands in the ballistic bin and misses its
// neighbour by ~10 standard errors at 1e6 walks (docs/validation.md); at 32 points (f = 3%) it agrees.
TEST(AddingDoublingBins, ForwardPeakedSlabAt32Points) {
  LayerStack s = one_layer(1.0, 0.3, Spectrum(0.3), Spectrum(10.0), Spectrum(0.9));
  s.name = "matched g 0.9";
  expect_bins_match_walk(s, 40.0, 4, 6, 1000000, 32);
}

// The table mode's builder (materials/tables/layered_table) with Method::AddingDoubling against the
// same builder with the walk: every node's bins (3 nodes, grazing to normal), green, within 4.5
// standard errors and chi-square p > 1e-3; the CDF ends at 1 and the powers agree.
TEST(AddingDoublingBins, LayeredTableMatchesTheWalksTable) {
  LayerStack s = one_layer(1.4, 0.3, Spectrum(0.3), Spectrum(10.0), Spectrum(0.5));
  TableSettings ts;
  ts.nodes = 3;
  ts.bins_theta = 3;
  ts.bins_phi = 4;
  ts.walks_per_node = 200000;
  ts.method = TableSettings::Method::MonteCarlo;
  TableSettings ad_settings = ts;
  ad_settings.method = TableSettings::Method::AddingDoubling;
  const LayeredTable mc = build_layered_table(s, ts);
  const LayeredTable ad = build_layered_table(s, ad_settings);
  // The walk's standard errors of the same bins (the table keeps only the values).
  double chi2 = 0.0;
  int dof = 0;
  for (int j = 0; j < ts.nodes; ++j) {
    BrdfOptions o;
    o.theta_i_deg = std::acos(table_node_cosine(ts, j)) * 180.0 / 3.14159265358979323846;
    o.samples = ts.walks_per_node;
    o.bins_theta = ts.bins_theta;
    o.bins_phi = ts.bins_phi;
    o.seed = ts.seed + 1000003ull * j;
    const BrdfTable walk = brdf_table_monte_carlo(s, o);  // the same walks as the table's node j
    for (int b = 0; b < ad.bins(); ++b) {
      ASSERT_EQ(walk.value[b][1], mc.at(j, b)[1]);
      const double se = walk.stderr_[b][1];
      if (se == 0.0) continue;
      const double z = (ad.at(j, b)[1] - mc.at(j, b)[1]) / se;
      EXPECT_LT(std::abs(z), 4.5) << "node " << j << " bin " << b;
      chi2 += z * z;
      ++dof;
    }
    EXPECT_DOUBLE_EQ(ad.cdf[static_cast<std::size_t>(j) * ad.bins() + ad.bins() - 1], 1.0);
    EXPECT_NEAR(ad.power[j], mc.power[j], 0.02 * mc.power[j]);
  }
  EXPECT_GT(test::chi_square_p_value(chi2, dof), 1e-3) << chi2 << " / " << dof;
}

// The table builder's choice (TableSettings): adding-doubling at the given order where delta-M
// leaves little out (skin, g 0.8: 0.8^28), a higher order for g = 0.9 (0.9^N <= 3%), the walk for a
// backward lobe the truncated series cannot resolve (g = -0.9: 0.9^28 = 5%).
TEST(AddingDoublingBins, TableChoosesOrderOrFallsBackToTheWalk) {
  TableSettings ts;
  ts.nodes = 2;
  ts.bins_theta = 2;
  ts.bins_phi = 2;
  ts.walks_per_node = 1000;
  const LayerStack skin = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  const LayeredTable a = build_layered_table(skin, ts);
  EXPECT_FALSE(a.walk_fallback);
  EXPECT_EQ(a.quadrature_points, 16);
  const LayeredTable b = build_layered_table(one_layer(1.0, 0.3, Spectrum(0.3), Spectrum(10.0), Spectrum(0.9)), ts);
  EXPECT_FALSE(b.walk_fallback);
  EXPECT_GE(b.quadrature_points, 32);
  EXPECT_LE(delta_m_truncation(one_layer(1.0, 0.3, Spectrum(0.3), Spectrum(10.0), Spectrum(0.9)), order(b.quadrature_points)).forward, 0.03);
  const LayeredTable c = build_layered_table(one_layer(1.4, 0.2, Spectrum(0.3), Spectrum(6.0), Spectrum(-0.9)), ts);
  EXPECT_TRUE(c.walk_fallback);
}

// A hang is a failure, not a stuck suite: runs f on a thread of its own and ends the test binary
// (exit 1, naming the test) if it has not returned after `seconds`; a looping thread cannot be
// stopped any other way.
template <class F>
auto finishes_within(double seconds, F f) -> decltype(f()) {
  using Result = decltype(f());
  auto task = std::make_shared<std::packaged_task<Result()>>(std::move(f));
  std::future<Result> result = task->get_future();
  std::thread([task] { (*task)(); }).detach();
  if (result.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready) {
    std::fprintf(stderr, "%s: still running after %g s (a hang)\n",
                 ::testing::UnitTest::GetInstance()->current_test_info()->name(), seconds);
    std::fflush(stderr);
    std::_Exit(1);
  }
  return result.get();
}

constexpr double kHangSeconds = 120.0;

// A finite layer whose optical depth overflows a double (here a thickness of 1e307 mm at
// sigma_t ~ 100/mm, and a sigma_s of 1e308/mm in a 10 mm layer) is its semi-infinite limit:
// nothing transmitted, and the reflection of the same layer made semi-infinite and of the same
// layer at the finite optical depth 1e302, which doubling reaches in ~1000 steps.
TEST(AddingDoubling, OverflowingOpticalDepthIsTheSemiInfiniteLimit) {
  const Spectrum sa(0.1, 0.5, 2.0), ss(100.0), g(0.5);
  const LayerStack thick = one_layer(1.4, 1e307, sa, ss, g);
  const LayerStack deep = one_layer(1.4, 1e300, sa, ss, g);
  const LayerStack semi = one_layer(1.4, kInfiniteThickness, sa, ss, g);
  ASSERT_TRUE(std::isinf(thick.layers[0].optical_depth(0)));
  const AddingDoublingTotals t = finishes_within(kHangSeconds, [&] { return adding_doubling_totals(thick, 0.8); });
  const AddingDoublingTotals d = adding_doubling_totals(deep, 0.8), s = adding_doubling_totals(semi, 0.8);
  // Doubling the 1e302 slab stops once nothing is transmitted (T exactly 0), not after all
  // ~1000 steps per channel (3033 before): 63.
  EXPECT_LT(d.doublings, 200);
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_EQ(total_T(t, c), 0.0);
    EXPECT_EQ(t.T_hemispherical[c], 0.0);
    EXPECT_NEAR(t.R_diffuse[c], d.R_diffuse[c], 1e-9) << c;
    EXPECT_NEAR(t.R_diffuse[c], s.R_diffuse[c], 1e-9) << c;
    EXPECT_NEAR(t.R_hemispherical[c], s.R_hemispherical[c], 1e-9) << c;
    EXPECT_NEAR(t.absorbed[c], 1.0 - total_R(t, c), 1e-12) << c;
    EXPECT_GT(t.absorbed[c], 0.0) << c;
  }
  const LayerStack dense = one_layer(1.4, 10.0, Spectrum(0.1), Spectrum(1e308), Spectrum(0.0));
  ASSERT_TRUE(std::isinf(dense.layers[0].optical_depth(0)));
  const LayerStack dense_semi = one_layer(1.4, kInfiniteThickness, Spectrum(0.1), Spectrum(1e308), Spectrum(0.0));
  const AddingDoublingTotals x = finishes_within(kHangSeconds, [&] { return adding_doubling_totals(dense, 0.5); });
  const AddingDoublingTotals y = adding_doubling_totals(dense_semi, 0.5);
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_EQ(total_T(x, c), 0.0);
    EXPECT_EQ(x.R_diffuse[c], y.R_diffuse[c]);
    EXPECT_GT(x.R_diffuse[c], 0.9);  // almost conservative: sigma_a / sigma_s = 1e-309
  }
}

// The walk handles the same stack (it needs no optical depth up front); adding-doubling agrees
// with it within the walk's errors.
TEST(AddingDoublingVsWalk, OverflowingOpticalDepth) {
  LayerStack s = one_layer(1.4, 1e307, Spectrum(0.1, 0.5, 2.0), Spectrum(100.0), Spectrum(0.5));
  s.name = "thickness 1e307 mm";
  finishes_within(kHangSeconds, [&] {
    expect_matches_walk(s, 30.0, 20000);
    return 0;
  });
}

// A layer of overflowing optical depth in the middle of a stack hides what lies below it: the
// stack reflects as its top layer over that layer made semi-infinite, transmits nothing, and
// its bins and the table mode's tables (built by adding-doubling) are finite and the same.
TEST(AddingDoublingBins, OverflowingOpticalDepthInTheMiddle) {
  const Layer top = make_layer("top", 1.5, 0.05, Spectrum(1.0), Spectrum(30.0), Spectrum(0.3));
  const Layer mid = make_layer("mid", 1.33, 1e307, Spectrum(0.2, 0.5, 2.0), Spectrum(80.0), Spectrum(-0.2));
  ASSERT_TRUE(std::isinf(mid.optical_depth(0)));
  Layer mid_semi = mid;
  mid_semi.thickness = kInfiniteThickness;
  // The bottom's indices are among the top's, so both stacks have the same quadrature nodes.
  const Layer bottom = make_layer("bottom", 1.5, 0.1, Spectrum(0.5), Spectrum(2.0), Spectrum(0.8));
  const LayerStack s = stack_of({top, mid, bottom}), limit = stack_of({top, mid_semi});
  BrdfOptions o;
  o.theta_i_deg = 35.0;
  o.bins_theta = 4;
  o.bins_phi = 6;
  AddingDoublingTotals totals, limit_totals;
  const BrdfTable ad =
      finishes_within(kHangSeconds, [&] { return brdf_table_adding_doubling(s, o, order(16), &totals); });
  const BrdfTable lim = brdf_table_adding_doubling(limit, o, order(16), &limit_totals);
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_EQ(total_T(totals, c), 0.0);
    EXPECT_NEAR(totals.R_diffuse[c], limit_totals.R_diffuse[c], 1e-9) << c;
  }
  for (int side = 0; side < 2; ++side)
    for (int k = 0; k < o.bins_theta; ++k)
      for (int m = 0; m < o.bins_phi; ++m) {
        const int b = ad.bin_index(static_cast<BrdfSide>(side), k, m);
        for (int c = 0; c < kChannels; ++c) {
          ASSERT_TRUE(std::isfinite(ad.value[b][c])) << side << " " << k << " " << m;
          if (side == 1) {
            EXPECT_EQ(ad.value[b][c], 0.0);
          }
          EXPECT_NEAR(ad.value[b][c], lim.value[b][c], 1e-9) << side << " " << k << " " << m;
        }
      }
  TableSettings ts;
  ts.nodes = 3;
  ts.bins_theta = 3;
  ts.bins_phi = 4;
  ts.method = TableSettings::Method::AddingDoubling;
  const LayeredTable table = finishes_within(kHangSeconds, [&] { return build_layered_table(s, ts); });
  const LayeredTable limit_table = build_layered_table(limit, ts);
  EXPECT_FALSE(table.walk_fallback);
  for (int j = 0; j < ts.nodes; ++j) {
    EXPECT_NEAR(table.power[j], limit_table.power[j], 1e-9) << j;
    EXPECT_GT(table.power[j], 0.0) << j;
  }
}

TEST(AddingDoubling, RejectsBadArguments) {
  const LayerStack s = one_layer(1.0, 1.0, Spectrum(1.0), Spectrum(1.0), Spectrum(0.0));
  EXPECT_THROW(adding_doubling_totals(s, 0.0), std::invalid_argument);
  EXPECT_THROW(adding_doubling_totals(s, 1.5), std::invalid_argument);
  EXPECT_THROW(adding_doubling_totals(s, std::nan("")), std::invalid_argument);
  EXPECT_THROW(adding_doubling_totals(s, 1.0, order(1)), std::invalid_argument);
}

}  // namespace
}  // namespace lamina
