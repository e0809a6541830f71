// lamina brdf --method monte-carlo: published benchmarks, conservation, reciprocity, two
// independent estimators, spectral MIS against grey walks, extremes, determinism.
// Tolerances are k standard errors of the estimators (k = 4 unless said).
#include "materials/brdf/brdf_table.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "materials/interfaces/fresnel.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

using test::one_layer;

BrdfOptions options(double theta, std::uint64_t n, int k = 4, int m = 4, std::uint64_t seed = 1) {
  BrdfOptions o;
  o.theta_i_deg = theta;
  o.samples = n;
  o.bins_theta = k;
  o.bins_phi = m;
  o.seed = seed;
  return o;
}

Spectrum sum_of_totals(const EnergyTotals& t) {
  return t.R_specular.value + t.R_diffuse.value + t.T_ballistic.value + t.T_diffuse.value + t.absorbed.value;
}

double hypot3(double a, double b, double c = 0.0) { return std::sqrt(a * a + b * b + c * c); }

// MCML test case (Wang, Jacques and Zheng 1995, table 2; van de Hulst 1980): n = 1 everywhere,
// mu_a = 1/mm, mu_s = 9/mm, g = 0.75, 0.2 mm, normal incidence: diffuse reflectance 0.09739,
// total transmittance 0.66096 (ballistic exp(-2) included). Published to 5 digits: the rounding
// (5e-6) is far below 4 standard errors here.
TEST(BrdfMonteCarlo, McmlSlabMatchesVanDeHulst) {
  const LayerStack s = one_layer(1.0, 0.2, Spectrum(1.0), Spectrum(9.0), Spectrum(0.75));
  const BrdfTable t = brdf_table_monte_carlo(s, options(0.0, 400000));
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_NEAR(t.totals.R_diffuse.value[c], 0.09739, 4.0 * t.totals.R_diffuse.stderr_[c] + 5e-6);
    const double tt = t.totals.T_ballistic.value[c] + t.totals.T_diffuse.value[c];
    const double se = hypot3(t.totals.T_ballistic.stderr_[c], t.totals.T_diffuse.stderr_[c]);
    EXPECT_NEAR(tt, 0.66096, 4.0 * se + 5e-6);
    EXPECT_EQ(t.totals.R_specular.value[c], 0.0);
  }
  // The ballistic part is exp(-tau) (analytic), and the walk's unscattered exits estimate it.
  EXPECT_NEAR(t.totals.T_ballistic.value[0], std::exp(-2.0), 1e-14);
  EXPECT_NEAR(t.totals.T_ballistic_walk.value[0], std::exp(-2.0), 4.0 * t.totals.T_ballistic_walk.stderr_[0]);
}

// Semi-infinite medium n = 1.5 under air, mu_a = 1, mu_s = 9, g = 0, normal incidence:
// Giovanelli (1955) total reflectance 0.2600 including the specular 0.04 (as quoted in the MCML
// paper). Published to 4 digits: tolerance max(4 sigma, 5e-5).
TEST(BrdfMonteCarlo, SemiInfiniteMatchesGiovanelli) {
  const LayerStack s = one_layer(1.5, kInfiniteThickness, Spectrum(1.0), Spectrum(9.0), Spectrum(0.0));
  const BrdfTable t = brdf_table_monte_carlo(s, options(0.0, 200000));
  const double r = t.totals.R_specular.value[0] + t.totals.R_diffuse.value[0];
  const double se = hypot3(t.totals.R_specular.stderr_[0], t.totals.R_diffuse.stderr_[0]);
  EXPECT_NEAR(r, 0.2600, std::max(4.0 * se, 5e-5)) << "se " << se;
  EXPECT_EQ(t.totals.T_diffuse.value[0], 0.0);
}

// Energy: the five totals sum to 1 by construction (absorbed is the complement), and the walk's
// direct tally of absorption agrees with the complement within their errors, for random stacks.
TEST(BrdfMonteCarlo, EnergyBalanceRandomStacks) {
  std::mt19937_64 gen(2024);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 8; ++trial) {
    LayerStack s;
    s.above_ior = 1.0 + 0.5 * u(gen);
    const int layers = 1 + trial % 3;
    for (int j = 0; j < layers; ++j) {
      const Spectrum sa(2.0 * u(gen), 2.0 * u(gen), 2.0 * u(gen));
      const Spectrum ss(20.0 * u(gen), 20.0 * u(gen), 20.0 * u(gen));
      const Spectrum g(1.8 * u(gen) - 0.9, 1.8 * u(gen) - 0.9, 1.8 * u(gen) - 0.9);
      s.layers.push_back(make_layer("l", 1.0 + u(gen), 0.5 * u(gen), sa, ss, g));
    }
    if (trial % 2) {
      s.below.kind = Below::Kind::Lambert;
      s.below.albedo = Spectrum(u(gen), u(gen), u(gen));
    } else {
      s.below.ior = 1.0 + u(gen);
    }
    const double theta = 80.0 * u(gen);
    const BrdfTable t = brdf_table_monte_carlo(s, options(theta, 10000, 4, 4, trial));
    const Spectrum total = sum_of_totals(t.totals);
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_NEAR(total[c], 1.0, 1e-12);
      const double se = hypot3(t.totals.absorbed.stderr_[c], t.totals.absorbed_direct.stderr_[c]);
      EXPECT_NEAR(t.totals.absorbed.value[c], t.totals.absorbed_direct.value[c], 4.0 * se + 1e-12)
          << "trial " << trial << " channel " << c;
      EXPECT_GE(t.totals.R_diffuse.value[c], 0.0);
      // The walk's unscattered exits against the analytic zeroth order (adding method). These
      // exits are rare events (a few per thousand photons or fewer), where the sample standard
      // deviation is unreliable (0 if none was seen); a per-photon value x in [0, B] has
      // Var(x) <= B E[x], so sqrt(B V / N) with the analytic V bounds the true standard error.
      // B = 3: an unscattered walk keeps weight (1 - R) times a spectral MIS factor <= 3.
      const double n = 10000.0;
      const double extra_r = t.totals.R_specular.value[c] - fresnel_dielectric(std::cos(theta * kPi / 180.0), s.above_ior, s.layers[0].ior);
      const double se_r = std::max(t.totals.R_specular_walk.stderr_[c], std::sqrt(3.0 * std::max(0.0, extra_r) / n));
      const double se_t = std::max(t.totals.T_ballistic_walk.stderr_[c], std::sqrt(3.0 * t.totals.T_ballistic.value[c] / n));
      EXPECT_NEAR(t.totals.R_specular_walk.value[c], t.totals.R_specular.value[c], 4.0 * se_r + 1e-12) << "trial " << trial;
      EXPECT_NEAR(t.totals.T_ballistic_walk.value[c], t.totals.T_ballistic.value[c], 4.0 * se_t + 1e-12) << "trial " << trial;
    }
  }
}

// Conservative, index-matched slab: nothing is absorbed and R + T = 1 (the only losses would be
// roulette's, unbiased).
TEST(BrdfMonteCarlo, ConservativeIndexMatchedSlab) {
  const LayerStack s = one_layer(1.0, 0.5, Spectrum(0.0), Spectrum(10.0), Spectrum(0.5));
  const BrdfTable t = brdf_table_monte_carlo(s, options(30.0, 50000));
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_EQ(t.totals.absorbed_direct.value[c], 0.0);
    EXPECT_NEAR(t.totals.absorbed.value[c], 0.0, 4.0 * t.totals.absorbed.stderr_[c] + 1e-12);
  }
}

// Spectral MIS: one coloured walk estimates each channel as a grey walk with that channel's
// coefficients would (independent runs: combined standard errors).
TEST(BrdfMonteCarlo, SpectralWalkMatchesGreyWalks) {
  LayerStack rgb;
  rgb.above_ior = 1.0;
  rgb.layers.push_back(make_layer("a", 1.4, 0.2, Spectrum(0.2, 2.0, 0.0), Spectrum(10.0, 2.0, 30.0), Spectrum(0.8, 0.0, -0.5)));
  rgb.layers.push_back(make_layer("b", 1.3, 0.3, Spectrum(1.0, 0.1, 0.5), Spectrum(5.0, 20.0, 1.0), Spectrum(0.3)));
  rgb.below.ior = 1.1;
  const BrdfTable t = brdf_table_monte_carlo(rgb, options(45.0, 40000));
  for (int c = 0; c < kChannels; ++c) {
    LayerStack grey = rgb;
    for (Layer& l : grey.layers) {
      l.sigma_a = Spectrum(l.sigma_a[c]);
      l.lobes[0].sigma_s = Spectrum(l.lobes[0].sigma_s[c]);
      l.lobes[0].g = Spectrum(l.lobes[0].g[c]);
    }
    const BrdfTable tg = brdf_table_monte_carlo(grey, options(45.0, 40000, 4, 4, 99));
    const Estimate* a[] = {&t.totals.R_diffuse, &t.totals.T_diffuse, &t.totals.T_ballistic, &t.totals.absorbed};
    const Estimate* b[] = {&tg.totals.R_diffuse, &tg.totals.T_diffuse, &tg.totals.T_ballistic, &tg.totals.absorbed};
    for (int q = 0; q < 4; ++q)
      EXPECT_NEAR(a[q]->value[c], b[q]->value[c], 4.0 * hypot3(a[q]->stderr_[c], b[q]->stderr_[c]))
          << "channel " << c << " total " << q;
  }
}

// Two independent estimators of the same bin averages: the exits counted in bins (o.samples
// walks), and the connection ("next event") estimator averaged over each bin (connection_samples
// other walks). Every bin and channel within 4 standard errors; more than 20 of them non-zero.
void expect_bins_agree_with_connections(const LayerStack& s, const BrdfOptions& o, std::uint64_t connection_samples,
                                        const std::string& what) {
  const BrdfTable bins = brdf_table_monte_carlo(s, o);
  BrdfOptions o2 = o;
  o2.seed = 77;  // independent walks
  o2.samples = connection_samples;
  const BrdfTable conn = brdf_table_connection(s, o2);
  int compared = 0;
  for (std::size_t b = 0; b < bins.value.size(); ++b)
    for (int c = 0; c < kChannels; ++c) {
      const double se = hypot3(bins.stderr_[b][c], conn.stderr_[b][c]);
      EXPECT_NEAR(bins.value[b][c], conn.value[b][c], 4.0 * se + 1e-12) << what << ", bin " << b << " channel " << c;
      if (bins.value[b][c] > 0.0) ++compared;
    }
  EXPECT_GT(compared, 20) << what;
}

// Both sides, index-mismatched, Lambert substrate.
TEST(BrdfMonteCarlo, BinCountsAgreeWithConnectionEstimator) {
  const LayerStack mismatched = one_layer(1.5, 0.3, Spectrum(0.5), Spectrum(4.0, 6.0, 8.0), Spectrum(0.5), 1.0, 1.2);
  LayerStack lam = one_layer(1.3, 0.2, Spectrum(0.2, 0.5, 1.0), Spectrum(5.0), Spectrum(-0.3));
  lam.below.kind = Below::Kind::Lambert;
  lam.below.albedo = Spectrum(0.8, 0.5, 0.2);
  expect_bins_agree_with_connections(mismatched, options(50.0, 30000, 3, 4, 5), 5000, "index-mismatched slab");
  expect_bins_agree_with_connections(lam, options(50.0, 30000, 3, 4, 5), 5000, "Lambert substrate");
}

// The same agreement for the approximate similarity option (WalkOptions::similarity_after): the
// switched walk is a transport model of its own, and its exits and its connections must estimate
// the same bin averages. An event's connection stands for the straight exit of its next flight,
// so the switch must fall between an event's collision and its scattering (the event then
// scatters and flies in the similar stack, and connects through it); switching after the event's
// direction (exact phase, similar flight, exact connection) made the connections several
// standard errors darker than the exits on this forward-scattering slab.
TEST(BrdfMonteCarlo, BinCountsAgreeWithConnectionEstimatorAcrossTheSimilaritySwitch) {
  const LayerStack s = one_layer(1.4, 0.5, Spectrum(0.2, 0.5, 1.0), Spectrum(20.0), Spectrum(0.8), 1.0, 1.0);
  LayerStack similar;
  similarity_transform_into(s, &similar);
  for (int after : {1, 3}) {
    BrdfOptions o = options(30.0, 60000, 3, 4, 5);
    o.walk.similarity_after = after;
    o.walk.similar = &similar;
    expect_bins_agree_with_connections(s, o, 10000, "similarity after " + std::to_string(after));
  }
}

// Reciprocity (Helmholtz): f(wi -> wo) = f(wo -> wi) for the BRDF; for the BTDF between media
// n_above and n_below, f_t(wi -> wo) / n_below^2 = f_t(wo' -> wi') / n_above^2 with wo' = -wo
// seen from below (Veach's thesis, eq. 5.19). Tested on the BRDF with two independent runs.
TEST(BrdfMonteCarlo, ReciprocityOfBrdf) {
  LayerStack s = one_layer(1.4, 0.3, Spectrum(0.3), Spectrum(8.0), Spectrum(0.6));
  s.layers.push_back(make_layer("under", 1.2, kInfiniteThickness, Spectrum(0.5), Spectrum(3.0), Spectrum(-0.2)));
  const double pairs[][3] = {{10.0, 60.0, 0.0}, {30.0, 75.0, 130.0}, {0.0, 45.0, 0.0}};
  for (const auto& p : pairs) {
    const glm::dvec3 a = incident_direction(p[0], 0.0), b = incident_direction(p[1], p[2]);
    const PointEstimate ab = brdf_connection_estimate(s, a, {b}, 8000, 1)[0];
    const PointEstimate ba = brdf_connection_estimate(s, b, {a}, 8000, 2)[0];
    for (int c = 0; c < kChannels; ++c)
      EXPECT_NEAR(ab.total.value[c], ba.total.value[c], 3.5 * hypot3(ab.total.stderr_[c], ba.total.stderr_[c]))
          << p[0] << " " << p[1];
  }
}

// Generalised reciprocity of the BTDF (Veach's thesis eq. 5.20): with wi in the medium above
// (index n_a) and wo in the medium below (n_b), f_t(wi -> wo) / n_b^2 = f_t'(wo -> wi) / n_a^2,
// where f_t' is the BTDF for light from below, i.e. of flipped(stack) with z negated. Tests the
// n^2 law in the transmitted connection weights (a missing or inverted factor fails by
// (n_b/n_a)^2 = 2.25 here).
TEST(BrdfMonteCarlo, GeneralisedReciprocityOfBtdf) {
  LayerStack s = one_layer(1.4, 0.3, Spectrum(0.3), Spectrum(5.0), Spectrum(0.6), 1.0, 1.5);
  s.layers.push_back(make_layer("under", 1.2, 0.2, Spectrum(0.5), Spectrum(3.0), Spectrum(-0.2)));
  const LayerStack f = flipped(s);
  const double n_a = 1.0, n_b = 1.5;
  const double pairs[][3] = {{10.0, 40.0, 30.0}, {50.0, 20.0, 170.0}};
  for (const auto& p : pairs) {
    const glm::dvec3 wi = incident_direction(p[0], 0.0);
    const glm::dvec3 wo = -incident_direction(p[1], p[2]);  // below
    const glm::dvec3 wi_f{wo.x, wo.y, -wo.z}, wo_f{wi.x, wi.y, -wi.z};  // flipped frame
    const PointEstimate forward = brdf_connection_estimate(s, wi, {wo}, 8000, 3)[0];
    const PointEstimate backward = brdf_connection_estimate(f, wi_f, {wo_f}, 8000, 4)[0];
    for (int c = 0; c < kChannels; ++c)
      EXPECT_NEAR(forward.total.value[c] / (n_b * n_b), backward.total.value[c] / (n_a * n_a),
                  3.5 * hypot3(forward.total.stderr_[c] / (n_b * n_b), backward.total.stderr_[c] / (n_a * n_a)))
          << p[0] << " " << p[1];
  }
}

// Heavy tails. A conservative half-space (albedo 1, n 1.4, g 0.9, normal
// incidence) absorbs nothing, yet 1 - R - T comes out near 1 % at the default settings: the walks
// still running after forced_exponential_after interactions carry that power, and the final
// roulette (survival 0.99 per interaction) turns it into a lottery the average almost never
// wins. `unresolved` reports it. With the cap lowered to 20000 (so that it matters a lot, and the
// test is fast) the apparent absorption must be explained by it: |absorbed - unresolved| within
// 4 standard errors, and unresolved clearly positive; walks that never reach the cap report 0.
TEST(BrdfMonteCarlo, UnresolvedTailExplainsApparentAbsorption) {
  const LayerStack s = one_layer(1.4, kInfiniteThickness, Spectrum(0.0), Spectrum(10.0), Spectrum(0.9));
  BrdfOptions o;
  o.samples = 20000;
  o.theta_i_deg = 0.0;
  o.walk.forced_exponential_after = 20000;
  const BrdfTable t = brdf_table_monte_carlo(s, o);
  const Estimate& a = t.totals.absorbed;
  const Estimate& u = t.totals.unresolved;
  EXPECT_GT(t.totals.unresolved_walks, 50u);
  EXPECT_GT(u.value[0], 6.0 * u.stderr_[0]);
  EXPECT_GT(a.value[0], 6.0 * a.stderr_[0]) << "the tail should look like absorption";
  EXPECT_NEAR(a.value[0], u.value[0], 4.0 * std::hypot(a.stderr_[0], u.stderr_[0]));
  // An absorbing slab's walks end long before the cap.
  const LayerStack thin = one_layer(1.4, 0.5, Spectrum(1.0), Spectrum(5.0), Spectrum(0.5));
  o.samples = 2000;
  const BrdfTable t2 = brdf_table_monte_carlo(thin, o);
  EXPECT_EQ(t2.totals.unresolved_walks, 0u);
  EXPECT_EQ(t2.totals.unresolved.value[0], 0.0);
}

// lamina brdf's progress callback sees every photon exactly once.
TEST(BrdfMonteCarlo, ProgressCountsEveryPhoton) {
  const LayerStack s = one_layer(1.3, 0.2, Spectrum(0.5), Spectrum(5.0), Spectrum(0.2));
  BrdfOptions o;
  o.samples = 10007;
  std::atomic<std::uint64_t> seen{0};
  o.on_progress = [&](std::uint64_t n) { seen += n; };
  brdf_table_monte_carlo(s, o);
  EXPECT_EQ(seen.load(), o.samples);
}

// Numerics at the extremes: finite, balanced (the direct absorption tally agrees with the
// complement), non-negative; walks end.
TEST(BrdfMonteCarlo, ExtremesStayFiniteAndBalanced) {
  struct Case {
    double n, thickness, sa, ss, g, above, below, theta;
  };
  std::vector<Case> cases;
  for (double g : {-0.9999, -1e-9, 0.0, 1e-9, 0.9999}) cases.push_back({1.4, 0.5, 0.5, 10.0, g, 1.0, 1.0, 30.0});
  for (double sa : {0.0, 1e-12}) cases.push_back({1.4, 0.5, sa, 10.0, 0.3, 1.0, 1.0, 30.0});
  cases.push_back({1.4, 0.5, 10.0, 0.0, 0.3, 1.0, 1.0, 30.0});  // albedo 0
  for (double t : {0.0, 1e-9, 1e6, kInfiniteThickness}) cases.push_back({1.4, t, 0.5, 10.0, 0.3, 1.0, 1.0, 30.0});
  for (double theta : {0.0, 89.99}) cases.push_back({1.4, 0.5, 0.5, 10.0, 0.3, 1.0, 1.0, theta});
  for (double n : {1.0, 1.0001, 2.5}) cases.push_back({n, 0.5, 0.5, 10.0, 0.3, 1.0, 1.0, 30.0});
  cases.push_back({1.0, 0.5, 0.5, 10.0, 0.3, 2.5, 2.5, 60.0});        // TIR on entry and exit
  cases.push_back({2.5, 0.5, 0.0, 0.05, 0.0, 1.0, 1.0, 30.0});       // TIR trap, thin medium
  cases.push_back({1.4, 0.0, 0.5, 10.0, 0.3, 1.0, 1.0, 30.0});       // empty thin film
  for (const Case& k : cases) {
    const LayerStack s = one_layer(k.n, k.thickness, Spectrum(k.sa), Spectrum(k.ss), Spectrum(k.g), k.above, k.below);
    ASSERT_EQ(validate_stack(s), "");
    const BrdfTable t = brdf_table_monte_carlo(s, options(k.theta, 4000, 3, 3, 3));
    const std::string label = "n " + std::to_string(k.n) + " t " + std::to_string(k.thickness) + " g " +
                              std::to_string(k.g) + " theta " + std::to_string(k.theta);
    for (std::size_t b = 0; b < t.value.size(); ++b) {
      ASSERT_TRUE(t.value[b].is_finite()) << label;
      ASSERT_GE(t.value[b].min(), 0.0) << label;
    }
    const Estimate* all[] = {&t.totals.R_specular, &t.totals.R_diffuse, &t.totals.T_ballistic,
                             &t.totals.T_diffuse, &t.totals.absorbed, &t.totals.absorbed_direct};
    for (const Estimate* e : all) ASSERT_TRUE(e->value.is_finite() && e->stderr_.is_finite()) << label;
    EXPECT_NEAR(sum_of_totals(t.totals)[0], 1.0, 1e-12) << label;
    // Rare-event floor: a part of probability p is missed by all N photons with probability
    // (1-p)^N < e^-6 once p > 6/N, and a photon carries weight <= B = 3 (spectral MIS bound),
    // so an unseen part (zero sample error) is consistent only below 6 B / N.
    EXPECT_NEAR(t.totals.absorbed.value[0], t.totals.absorbed_direct.value[0],
                4.0 * hypot3(t.totals.absorbed.stderr_[0], t.totals.absorbed_direct.stderr_[0]) + 18.0 / 4000)
        << label;
  }
}

// Continuity across thresholds: with the same seed, g = 1e-9 vs g = 0 and albedo 1 - 1e-12 vs 1
// change each walk by O(1e-9) (directions) or O(1e-12) (weights); a discrete decision flips with
// probability of that order, so the totals agree far inside their standard errors.
TEST(BrdfMonteCarlo, ContinuousAcrossThresholds) {
  auto totals = [](double g, double sa, double thickness, double n) {
    return brdf_table_monte_carlo(one_layer(n, thickness, Spectrum(sa), Spectrum(10.0), Spectrum(g)),
                                  options(30.0, 10000, 2, 2, 8))
        .totals;
  };
  auto expect_close = [](const EnergyTotals& a, const EnergyTotals& b, double rel_sigma, const char* what) {
    EXPECT_NEAR(a.R_diffuse.value[0], b.R_diffuse.value[0], rel_sigma * a.R_diffuse.stderr_[0] + 1e-9) << what;
    EXPECT_NEAR(a.T_diffuse.value[0], b.T_diffuse.value[0], rel_sigma * a.T_diffuse.stderr_[0] + 1e-9) << what;
  };
  // g = 0 samples the sphere directly (no frame about the direction), any other g the
  // Henyey-Greenstein inverse CDF: the same distribution by two mappings, so g = 0 against
  // g = 1e-9 agrees statistically (4 standard errors of the difference, the two taken as
  // independent, which over-covers: they share their first flights), and the inverse CDF is
  // continuous, path for path, as g -> 0 (1e-9 against 1e-6).
  expect_close(totals(1e-9, 0.5, 0.5, 1.4), totals(1e-6, 0.5, 0.5, 1.4), 0.05, "g");
  {
    const EnergyTotals a = totals(0.0, 0.5, 0.5, 1.4), b = totals(1e-9, 0.5, 0.5, 1.4);
    EXPECT_NEAR(a.R_diffuse.value[0], b.R_diffuse.value[0], 4.0 * std::hypot(a.R_diffuse.stderr_[0], b.R_diffuse.stderr_[0]));
    EXPECT_NEAR(a.T_diffuse.value[0], b.T_diffuse.value[0], 4.0 * std::hypot(a.T_diffuse.stderr_[0], b.T_diffuse.stderr_[0]));
  }
  expect_close(totals(0.3, 0.0, 0.5, 1.4), totals(0.3, 1e-12, 0.5, 1.4), 0.05, "albedo");
  expect_close(totals(0.3, 0.5, 0.0, 1.4), totals(0.3, 0.5, 1e-9, 1.4), 0.05, "thickness");
  // Index ratio 1 -> 1.0001 changes Fresnel by ~1e-9 at most angles (grazing aside).
  expect_close(totals(0.3, 0.5, 0.5, 1.0), totals(0.3, 0.5, 0.5, 1.0001), 0.5, "index");
}

// Same bits for any number of threads: photon i always uses Rng(seed, i) and blocks are fixed.
TEST(BrdfMonteCarlo, DeterministicAcrossThreadCounts) {
  LayerStack s = one_layer(1.4, 0.3, Spectrum(0.3, 0.6, 0.9), Spectrum(8.0), Spectrum(0.6));
  const BrdfOptions o = options(40.0, 6000, 4, 6, 12);
  BrdfTable one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = brdf_table_monte_carlo(s, o);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = brdf_table_monte_carlo(s, o);
  }
  EXPECT_TRUE(one.value == two.value);
  EXPECT_TRUE(one.stderr_ == two.stderr_);
  EXPECT_TRUE(one.totals.R_diffuse.value == two.totals.R_diffuse.value);
  EXPECT_TRUE(one.totals.absorbed.value == two.totals.absorbed.value);
}

// azimuth_bin uses an approximate atan2 away from the bins' edges: it must give the bin of the
// definition, floor((atan2(y, x) - phi_i) mod 2 pi / (2 pi) M), for every direction, including
// those just beside an edge (1e-5 to 1e-9 radians), where the approximation alone (error ~2e-8)
// would sometimes pick the neighbour.
TEST(BrdfMonteCarlo, AzimuthBinIsTheDefinitionsBin) {
  auto definition = [](double x, double y, double phi_i, int bins) {
    double phi = std::atan2(y, x) - phi_i;
    phi -= 2.0 * kPi * std::floor(phi / (2.0 * kPi));
    return std::clamp(static_cast<int>(phi / (2.0 * kPi) * bins), 0, bins - 1);
  };
  std::mt19937_64 gen(3);
  std::uniform_real_distribution<double> angle(-kPi, kPi), radius(1e-3, 1.0);
  int checked = 0, mismatches = 0;
  for (int bins : {1, 7, 36, 360}) {
    for (double phi_i : {0.0, 0.3, -2.0}) {
      auto check = [&](double a, double r) {
        const double x = r * std::cos(a), y = r * std::sin(a);
        ++checked;
        if (azimuth_bin(x, y, phi_i, bins) != definition(x, y, phi_i, bins)) ++mismatches;
      };
      for (int i = 0; i < 100000; ++i) check(angle(gen), radius(gen));
      for (int m = 0; m < bins; ++m) {
        const double edge = phi_i + 2.0 * kPi * m / bins;
        for (double offset : {1e-5, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 1e-9})
          for (double sign : {-1.0, 1.0}) check(edge + sign * offset, radius(gen));
      }
    }
  }
  EXPECT_EQ(mismatches, 0) << "of " << checked << " directions";
}

}  // namespace
}  // namespace lamina
