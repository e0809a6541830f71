// The random walk itself: exactness of its bookkeeping (connection weight vs. the walk's own
// straight exits, grey = scalar, energy balance per photon), termination, extremes.
#include "materials/walk/random_walk.h"
#include "materials/walk/walk_kernel.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <vector>

#include <gtest/gtest.h>

#include "materials/brdf/brdf_table.h"
#include "materials/interfaces/fresnel.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

using test::one_layer;

// A coloured two-layer stack on a Lambert substrate, with a two-lobe layer.
LayerStack coloured_stack() {
  LayerStack s;
  s.layers.push_back(make_layer("top", 1.4, 0.1, Spectrum(0.5, 1.0, 2.0), Spectrum(5.0, 10.0, 3.0),
                                Spectrum(0.3, 0.5, -0.2)));
  Layer mid = make_layer("mid", 1.3, 0.3, Spectrum(0.2, 0.1, 1.0), Spectrum(20.0, 10.0, 15.0), Spectrum(0.8));
  mid.lobes.push_back({Spectrum(5.0, 1.0, 0.0), Spectrum(-0.5, 0.0, 0.9)});
  s.layers.push_back(mid);
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.6, 0.4, 0.8);
  return s;
}

// For a walk in a grey stack that leaves straight from its last event, the exit weight equals
// the event's throughput (every sampling ratio is 1) and its density is connection_pdf; hence
// (see the derivation above connection_weight) W_exit * pdf / |mu_out| = throughput *
// connection_weight, to rounding. This ties the walk's sampling to the connection formulas:
// direction inside, Snell, Jacobian, attenuation, Fresnel, n^2, phase lobes, substrate.
// (In coloured stacks the MIS weight of the path changes between event and exit, so the identity
// holds only in expectation: BinCountsAgreeWithConnectionEstimator tests that.)
// Runs walks i = 0 .. walks-1 (Rng(seed, i)) from wi and, for each that leaves straight from its
// last event, checks W_exit * exit_pdf / |mu_out| = throughput * connection_weight to 1e-9, the
// connection through the stack `through(last)` returns (null: skip the walk). Returns how many
// walks were checked.
int check_straight_exits(const LayerStack& stack, const glm::dvec3& wi, const WalkOptions& settings,
                         std::uint64_t seed, int walks,
                         const std::function<const LayerStack*(const ScatterEvent&)>& through) {
  WalkOptions with_exit_pdf = settings;
  with_exit_pdf.compute_exit_pdf = true;
  int checked = 0;
  for (int i = 0; i < walks; ++i) {
    Rng rng(seed, static_cast<std::uint64_t>(i));
    ScatterEvent last;
    const WalkResult r = random_walk(stack, wi, rng, [&](const ScatterEvent& e) { last = e; }, with_exit_pdf);
    if (!r.straight_from_last_event) continue;
    const LayerStack* s = through(last);
    if (!s) continue;
    const Spectrum lhs = r.weight * (r.exit_pdf / std::abs(r.direction.z));
    const Spectrum rhs = last.throughput * connection_weight(*s, last, r.direction);
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_NEAR(lhs[c], rhs[c], 1e-9 * (1.0 + std::abs(rhs[c]))) << "walk " << i << " channel " << c;
      if (std::abs(lhs[c] - rhs[c]) > 1e-9 * (1.0 + std::abs(rhs[c]))) return checked;
    }
    ++checked;
  }
  return checked;
}

TEST(RandomWalk, StraightExitsMatchConnectionWeight) {
  LayerStack two_lobes = one_layer(1.3, 0.4, Spectrum(0.2), Spectrum(3.0), Spectrum(0.8), 1.1, 1.6);
  two_lobes.layers[0].lobes.push_back({Spectrum(2.0), Spectrum(-0.6)});
  two_lobes.layers.push_back(make_layer("under", 1.6, 0.2, Spectrum(0.4), Spectrum(6.0), Spectrum(0.2)));
  LayerStack lambert = one_layer(1.4, 0.3, Spectrum(0.3), Spectrum(2.0), Spectrum(0.5));
  lambert.below.kind = Below::Kind::Lambert;
  lambert.below.albedo = Spectrum(0.7);
  std::vector<LayerStack> stacks = {
      one_layer(1.0, 0.5, Spectrum(0.1), Spectrum(3.0), Spectrum(0.6)),
      one_layer(1.5, 0.5, Spectrum(0.1), Spectrum(3.0), Spectrum(-0.4)),
      one_layer(0.8, 0.5, Spectrum(0.1), Spectrum(3.0), Spectrum(0.2), 1.2, 1.7),
      two_lobes, lambert};
  WalkOptions no_roulette;
  no_roulette.roulette_threshold = 0.0;  // roulette would scale the exit weight after the event
  int checked = 0;
  for (const LayerStack& stack : stacks)
    for (double theta : {0.0, 40.0, 80.0})
      checked += check_straight_exits(stack, incident_direction(theta, 30.0), no_roulette, 7, 3000,
                                      [&](const ScatterEvent&) { return &stack; });
  EXPECT_GT(checked, 1000);
}

// A grey stack: every channel carries the same bits, as the scalar walk would.
TEST(RandomWalk, GreyStackKeepsChannelsIdentical) {
  LayerStack s = one_layer(1.33, 0.4, Spectrum(0.3), Spectrum(7.0), Spectrum(0.7), 1.0, 1.2);
  s.layers.push_back(make_layer("under", 1.5, 0.2, Spectrum(2.0), Spectrum(1.0), Spectrum(-0.3)));
  for (std::uint64_t i = 0; i < 5000; ++i) {
    Rng rng(3, i);
    const WalkResult r = random_walk(s, incident_direction(35.0, 0.0), rng, [&](const ScatterEvent& e) {
      ASSERT_EQ(e.throughput[0], e.throughput[1]);
      ASSERT_EQ(e.throughput[0], e.throughput[2]);
    });
    ASSERT_EQ(r.weight[0], r.weight[1]);
    ASSERT_EQ(r.weight[0], r.weight[2]);
  }
}

// The walk's loop run with a plain callable (walk_kernel::run_walk, as the renderer does) is the
// walk that random_walk runs with a std::function: the same events and result, bit for bit, and
// a callable is always called (a std::function only when it holds one).
TEST(RandomWalk, LoopWithACallableIsTheWalkWithAStdFunction) {
  const LayerStack s = test::skin_like_stack();
  WalkOptions settings;
  settings.roulette_threshold = 0.5;
  settings.roulette_survival = 0.5;
  WalkPlan plan;
  prepare_walk(s, settings, &plan);
  std::uint64_t events = 0;
  for (std::uint64_t i = 0; i < 3000; ++i) {
    std::vector<ScatterEvent> a, b;
    Rng rng_a(5, i), rng_b(5, i);
    const WalkResult ra = random_walk(plan, incident_direction(40.0, 0.0), rng_a,
                                      EventCallback([&](const ScatterEvent& e) { a.push_back(e); }), 1);
    const WalkResult rb =
        walk_kernel::run_walk(plan, incident_direction(40.0, 0.0), rng_b, [&](const ScatterEvent& e) { b.push_back(e); }, 1);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      ASSERT_EQ(a[k].depth, b[k].depth);
      ASSERT_EQ(a[k].direction, b[k].direction);
      for (int c = 0; c < kChannels; ++c) ASSERT_EQ(a[k].throughput[c], b[k].throughput[c]);
    }
    ASSERT_EQ(ra.side, rb.side);
    ASSERT_EQ(ra.direction, rb.direction);
    for (int c = 0; c < kChannels; ++c) ASSERT_EQ(ra.weight[c], rb.weight[c]);
    ASSERT_EQ(rng_a.uniform(), rng_b.uniform());  // the same random numbers used
    events += a.size();
  }
  EXPECT_GT(events, 10000u);
}

// LayerStack::grey: what lets lamina brdf tally one channel of the walks above for three.
TEST(LayerStackGrey, EveryCoefficientMustAgreeAcrossChannels) {
  LayerStack s = one_layer(1.33, 0.4, Spectrum(0.3), Spectrum(7.0), Spectrum(0.7), 1.0, 1.2);
  EXPECT_TRUE(s.grey());
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.5);
  EXPECT_TRUE(s.grey());
  s.below.albedo = Spectrum(0.5, 0.5, 0.4);
  EXPECT_FALSE(s.grey());
  s.below.albedo = Spectrum(0.5);
  s.layers[0].lobes[0].g = Spectrum(0.7, 0.7, 0.6);
  EXPECT_FALSE(s.grey());
  s.layers[0].lobes[0].g = Spectrum(0.7);
  s.layers[0].lobes.push_back({Spectrum(1.0, 2.0, 1.0), Spectrum(0.0)});
  EXPECT_FALSE(s.grey());
  s.layers[0].lobes.back().sigma_s = Spectrum(1.0);
  s.layers[0].sigma_a = Spectrum(0.3, 0.3, 0.31);
  EXPECT_FALSE(s.grey());
  EXPECT_FALSE(coloured_stack().grey());
}

// Without roulette, each collision splits the weight w into w*albedo (scattered) and
// w*(1-albedo) (absorbed), each substrate hit likewise, so for a grey stack every photon's exits
// plus its direct absorption equal 1 - R_fresnel to rounding.
TEST(RandomWalk, GreyPhotonConservesEnergyWithoutRoulette) {
  LayerStack s = one_layer(1.4, 0.3, Spectrum(0.5), Spectrum(5.0), Spectrum(0.5));
  s.layers.push_back(make_layer("under", 1.2, 0.5, Spectrum(0.1), Spectrum(4.0), Spectrum(0.0)));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.7);
  WalkOptions settings;
  settings.roulette_threshold = 0.0;
  settings.forced_after = 1 << 30;
  settings.forced_exponential_after = 1 << 30;
  const glm::dvec3 wi = incident_direction(20.0, 0.0);
  const double r0 = fresnel_dielectric(wi.z, 1.0, 1.4);
  for (std::uint64_t i = 0; i < 5000; ++i) {
    Rng rng(11, i);
    const WalkResult r = random_walk(s, wi, rng, {}, settings);
    ASSERT_NE(r.end, WalkResult::End::Roulette);
    ASSERT_NEAR(r.weight[0] + r.absorbed[0], 1.0 - r0, 1e-12);
  }
}

// Albedo 1, semi-infinite, index-mismatched: nothing absorbs and a walk may wander for ever; the
// forced roulette must end every walk, and do so without bias: the expected exit weight is still
// 1 - R_fresnel (all entering power comes back out).
TEST(RandomWalk, AlbedoOneSemiInfiniteEndsAndConserves) {
  const LayerStack s = one_layer(1.5, kInfiniteThickness, Spectrum(0.0), Spectrum(10.0), Spectrum(0.0));
  const glm::dvec3 wi = incident_direction(0.0, 0.0);
  // Earlier forced roulette than the default (same schedule), to keep the test short.
  WalkOptions settings;
  settings.forced_after = 100;
  settings.forced_exponential_after = 100000;
  const int n = 10000;
  double sum = 0.0, sum2 = 0.0;
  int roulette = 0, exits = 0;
  for (int i = 0; i < n; ++i) {
    Rng rng(5, i);
    const WalkResult r = random_walk(s, wi, rng, {}, settings);
    ASSERT_TRUE(r.weight.is_finite());
    if (r.end == WalkResult::End::Roulette) ++roulette;
    if (r.end == WalkResult::End::ExitTop) ++exits;
    ASSERT_TRUE(r.end == WalkResult::End::Roulette || r.end == WalkResult::End::ExitTop);
    ASSERT_EQ(r.absorbed[0], 0.0);
    sum += r.weight[0];
    sum2 += r.weight[0] * r.weight[0];
  }
  EXPECT_GT(roulette, 0);  // the forced roulette was exercised
  EXPECT_EQ(roulette + exits, n);
  const double mean = sum / n;
  const double se = std::sqrt((sum2 / n - mean * mean) / (n - 1));
  EXPECT_NEAR(mean, 1.0 - 0.04, 4.0 * se) << "se " << se;
}

// Spectral MIS keeps weights bounded: W_c <= 3 a_c <= 3 (entry transmission and albedos <= 1),
// without roulette, even for a strongly coloured stack with a multi-lobe layer and a substrate.
TEST(RandomWalk, ColouredWeightsBounded) {
  const LayerStack s = coloured_stack();
  WalkOptions no_roulette;
  no_roulette.roulette_threshold = 0.0;
  int events = 0;
  for (std::uint64_t i = 0; i < 5000; ++i) {
    Rng rng(13, i);
    const WalkResult r = random_walk(s, incident_direction(60.0, 10.0), rng, [&](const ScatterEvent& e) {
      ASSERT_TRUE(e.throughput.is_finite());
      ASSERT_LE(e.throughput.max(), 3.0);
      ASSERT_GE(e.throughput.min(), 0.0);
      ++events;
    }, no_roulette);
    ASSERT_TRUE(r.weight.is_finite());
    ASSERT_LE(r.weight.max(), 3.0);
    ASSERT_NE(r.end, WalkResult::End::Lost);
  }
  EXPECT_GT(events, 5000);
}

// The all-paths connection adds the specularly bounced paths to the direct one: equal to it where
// no interface reflects (index-matched), larger otherwise.
TEST(RandomWalk, AllPathsConnectionContainsTheDirectPath) {
  LayerStack matched = one_layer(1.0, 0.4, Spectrum(0.2, 0.5, 1.0), Spectrum(4.0), Spectrum(0.5));
  matched.layers.push_back(make_layer("b", 1.0, 0.3, Spectrum(0.1), Spectrum(2.0, 3.0, 4.0), Spectrum(-0.2)));
  LayerStack mismatched = matched;
  mismatched.layers[0].ior = 1.5;
  mismatched.layers[1].ior = 1.3;
  for (const glm::dvec3& w : {incident_direction(20.0, 30.0), incident_direction(80.0, 200.0),
                              -incident_direction(40.0, 10.0)}) {
    for (int layer : {0, 1}) {
      ScatterEvent e;
      e.layer = layer;
      e.depth = 0.1;
      e.direction = glm::normalize(glm::dvec3(0.3, -0.2, -0.9));
      const Spectrum direct = connection_weight(matched, e, w), all = connection_weight_all_paths(matched, e, w);
      const Spectrum direct_m = connection_weight(mismatched, e, w), all_m = connection_weight_all_paths(mismatched, e, w);
      for (int c = 0; c < kChannels; ++c) {
        EXPECT_NEAR(all[c], direct[c], 1e-14 * (1.0 + direct[c]));
        EXPECT_GT(all_m[c], direct_m[c]);
      }
    }
  }
}

// The direct connection_weight against the walk's own straight exits, statistically, in a
// coloured, index-mismatched, transmitting stack (where the exact identity of
// StraightExitsMatchConnectionWeight does not hold): binned exits flagged
// straight_from_last_event estimate, per bin, the same thing as sum over events of
// throughput * connection_weight(w) with w uniform in projected solid angle over the bin.
TEST(RandomWalk, StraightExitsAgreeWithDirectConnectionInColour) {
  LayerStack s = one_layer(2.4, 0.3, Spectrum(0.2, 0.6, 1.5), Spectrum(6.0, 3.0, 8.0), Spectrum(0.6, 0.0, -0.4), 1.0, 1.2);
  s.layers.push_back(make_layer("b", 1.3, 0.3, Spectrum(0.5), Spectrum(4.0, 8.0, 2.0), Spectrum(0.3)));
  const int K = 3, M = 4, nb = 2 * K * M;
  const std::uint64_t n = 10000;
  const glm::dvec3 wi = incident_direction(35.0, 0.0);
  auto omega = [&](int k) {
    const double lo = double(k) / K, hi = double(k + 1) / K;
    return 0.5 * (hi * hi - lo * lo) * 2.0 * kPi / M;
  };
  std::vector<double> a_sum(nb * 3), a_sum2(nb * 3), b_sum(nb * 3), b_sum2(nb * 3);
  Spectrum w_sum, w_sum2, b_total, b_total2;
  for (std::uint64_t i = 0; i < n; ++i) {
    // A: the walk's straight exits.
    Rng rng(41, i);
    const WalkResult r = random_walk(s, wi, rng);
    if (r.straight_from_last_event) {
      w_sum += r.weight;
      w_sum2 += r.weight * r.weight;
      const int side = r.direction.z > 0 ? 0 : 1;
      const int k = std::min(K - 1, int(std::abs(r.direction.z) * K));
      double phi = std::atan2(r.direction.y, r.direction.x);
      if (phi < 0) phi += 2 * kPi;
      const int m = std::min(M - 1, int(phi / (2 * kPi) * M));
      const int b = (side * K + k) * M + m;
      for (int c = 0; c < 3; ++c) {
        const double v = r.weight[c] / omega(k);
        a_sum[b * 3 + c] += v;
        a_sum2[b * 3 + c] += v * v;
      }
    }
    // B: the direct connections of an independent walk's events.
    Rng rng2(43, i), dirs(43, i, 1);
    std::vector<glm::dvec3> w(nb);
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < K; ++k)
        for (int m = 0; m < M; ++m) {
          const double lo = double(k) / K, hi = double(k + 1) / K;
          const double mu = std::sqrt(lo * lo + dirs.uniform() * (hi * hi - lo * lo));
          const double phi = 2 * kPi * (m + dirs.uniform()) / M;
          const double st = std::sqrt(std::max(0.0, 1 - mu * mu));
          w[(side * K + k) * M + m] = {st * std::cos(phi), st * std::sin(phi), side == 0 ? mu : -mu};
        }
    std::vector<Spectrum> v(nb);
    random_walk(s, wi, rng2, [&](const ScatterEvent& e) {
      for (int b = 0; b < nb; ++b) v[b] += e.throughput * connection_weight(s, e, w[b]);
    });
    Spectrum b_walk;  // this walk's connections integrated over the sphere (bin values times Omega)
    for (int b = 0; b < nb; ++b) {
      b_walk += v[b] * omega((b / M) % K);
      for (int c = 0; c < 3; ++c) {
        b_sum[b * 3 + c] += v[b][c];
        b_sum2[b * 3 + c] += v[b][c] * v[b][c];
      }
    }
    b_total += b_walk;
    b_total2 += b_walk * b_walk;
  }
  // Pooled over the sphere, per channel: the straight exits' total weight against the integrated
  // connections. Each walk adds one value to each side, so these standard errors are honest (about
  // 2-3 %, the exits' noise): connection weights 15 % low fail here for each of six seeds tried,
  // while the bins' own comparisons, at 10 % low, catch it for one seed in five.
  for (int c = 0; c < 3; ++c) {
    const double nn = double(n);
    const double a = w_sum[c] / nn, b = b_total[c] / nn;
    const double va = std::max(0.0, w_sum2[c] / nn - a * a) / (nn - 1);
    const double vb = std::max(0.0, b_total2[c] / nn - b * b) / (nn - 1);
    EXPECT_NEAR(a, b, 4.0 * std::sqrt(va + vb)) << "all bins, channel " << c;
  }
  const double nn = double(n);
  int compared = 0;
  for (int j = 0; j < nb * 3; ++j) {
    const double a = a_sum[j] / nn, b = b_sum[j] / nn;
    const double va = std::max(0.0, a_sum2[j] / nn - a * a) / (nn - 1), vb = std::max(0.0, b_sum2[j] / nn - b * b) / (nn - 1);
    const int k = (j / 3 / M) % K;
    // Rare-bin floor for the exit counts (the sample variance of a few hits is unreliable): an
    // exit lands in the bin with probability p and adds w / (Omega N), so a's mean is
    // p E[w] / Omega and its variance p E[w^2] / (Omega^2 N) = a (E[w^2] / E[w]) / (Omega N),
    // with b for a and the moments of all straight exits' weights (spectral MIS weights vary
    // by up to 3x between walks: E[w^2] / E[w], not E[w], or the floor is too low; with E[w]
    // a quarter of the seeds failed some bin).
    const double w_ratio = w_sum2[j % 3] / std::max(w_sum[j % 3], 1e-300);
    const double floor_a = w_ratio * b / (omega(k) * nn);
    EXPECT_NEAR(a, b, 4.0 * std::sqrt(std::max(va, floor_a) + vb) + 1e-12) << "bin " << j / 3 << " channel " << j % 3;
    if (b > 0) ++compared;
  }
  EXPECT_GT(compared, 40);
}

// The connection weight vanishes where no inside direction exists and towards sides that do not
// transmit; it is finite at grazing and normal directions.
TEST(RandomWalk, ConnectionWeightDomain) {
  const LayerStack semi = one_layer(1.5, kInfiniteThickness, Spectrum(1.0), Spectrum(9.0), Spectrum(0.0));
  ScatterEvent e;
  e.layer = 0;
  e.depth = 0.0;
  e.direction = {0.0, 0.0, -1.0};
  e.throughput = Spectrum(1.0);
  EXPECT_TRUE(connection_weight(semi, e, {0.0, 0.0, -1.0}).is_black());  // no transmission
  for (double mu : {1.0, 0.5, 1e-6, 1e-12}) {
    const glm::dvec3 w{std::sqrt(1 - mu * mu), 0.0, mu};
    const Spectrum v = connection_weight(semi, e, w);
    EXPECT_TRUE(v.is_finite());
    EXPECT_GE(v[0], 0.0);
    EXPECT_TRUE(std::isfinite(connection_pdf(semi, e, w)));
  }
  // A layer less dense than the outside (n = 1 under n = 1.5 above): outside directions beyond
  // asin(1/1.5) from the normal have no inside direction.
  const LayerStack rare = one_layer(1.0, 1.0, Spectrum(1.0), Spectrum(1.0), Spectrum(0.0), 1.5, 1.5);
  e.depth = 0.5;
  const double s = 0.9;  // sin > 1/1.5
  EXPECT_TRUE(connection_weight(rare, e, {s, 0.0, std::sqrt(1 - s * s)}).is_black());
  EXPECT_EQ(connection_pdf(rare, e, {s, 0.0, std::sqrt(1 - s * s)}), 0.0);
  EXPECT_FALSE(connection_weight(rare, e, {0.5, 0.0, std::sqrt(0.75)}).is_black());
}

// The hero argument. Default: the walk's first uniform picks the hero, as it always did (so
// `lamina brdf` and the tables keep their bits); a chosen hero is the one every event reports; and
// a walk given the hero that its own first uniform would have picked is the same walk, bit for
// bit (the uniform is drawn either way, so the later numbers come from the same place).
TEST(RandomWalk, CallerChosenHero) {
  const LayerStack s = coloured_stack();
  const glm::dvec3 wi = incident_direction(40.0, 0.0);
  for (int i = 0; i < 300; ++i) {
    Rng probe(5, i);
    const int drawn = std::min(kChannels - 1, static_cast<int>(probe.uniform() * kChannels));
    std::vector<int> heroes;
    Rng rng(5, i);
    const WalkResult r = random_walk(s, wi, rng, [&](const ScatterEvent& e) { heroes.push_back(e.hero); });
    for (int h : heroes) ASSERT_EQ(h, drawn) << "walk " << i;
    Rng rng_chosen(5, i);
    const WalkResult same = random_walk(s, wi, rng_chosen, {}, {}, drawn);
    ASSERT_EQ(r.end, same.end) << "walk " << i;
    for (int c = 0; c < kChannels; ++c) ASSERT_EQ(r.weight[c], same.weight[c]) << "walk " << i;
    const int other = (drawn + 1 + i % 2) % kChannels;
    Rng rng_other(5, i);
    random_walk(s, wi, rng_other, [&](const ScatterEvent& e) { ASSERT_EQ(e.hero, other); }, {}, other);
  }
}

// WalkOptions::tally_absorbed = false (the renderer) changes nothing but the absorbed tally:
// the same events, exits and weights, bit for bit, and no absorbed power. Without the flag the
// tally is there (the coloured stack absorbs in every layer and at the substrate).
TEST(RandomWalk, AbsorbedTallyIsOptional) {
  const LayerStack s = coloured_stack();
  const glm::dvec3 wi = incident_direction(30.0, 0.0);
  WalkOptions without;
  without.tally_absorbed = false;
  Spectrum tallied;
  for (int i = 0; i < 300; ++i) {
    std::vector<Spectrum> events, events_without;
    Rng rng(9, i), rng_without(9, i);
    const WalkResult r = random_walk(s, wi, rng, [&](const ScatterEvent& e) { events.push_back(e.throughput); });
    const WalkResult q = random_walk(s, wi, rng_without, [&](const ScatterEvent& e) { events_without.push_back(e.throughput); },
                                     without);
    ASSERT_EQ(r.end, q.end) << "walk " << i;
    ASSERT_EQ(events.size(), events_without.size()) << "walk " << i;
    for (std::size_t e = 0; e < events.size(); ++e)
      for (int c = 0; c < kChannels; ++c) ASSERT_EQ(events[e][c], events_without[e][c]) << "walk " << i;
    for (int c = 0; c < kChannels; ++c) {
      ASSERT_EQ(r.weight[c], q.weight[c]) << "walk " << i;
      ASSERT_EQ(q.absorbed[c], 0.0) << "walk " << i;
    }
    tallied += r.absorbed;
  }
  for (int c = 0; c < kChannels; ++c) EXPECT_GT(tallied[c], 0.0);
}

// ---- guided walks (WalkOptions::guiding) ----

// With guiding the exit weight is no longer the last event's throughput (the mixture's weight
// of the last flight comes in), but W_exit * exit_pdf / |mu_out| = throughput * connection_weight
// must still hold walk by walk, exit_pdf being the mixture density (connection_pdf with the
// same guiding): the exits and the connections are the two MIS techniques of the renderer.
TEST(RandomWalkGuided, StraightExitsMatchConnectionWeight) {
  LayerStack lambert = one_layer(1.4, 0.3, Spectrum(0.05), Spectrum(8.0), Spectrum(0.0));
  lambert.below.kind = Below::Kind::Lambert;
  lambert.below.albedo = Spectrum(0.7);
  // An isotropic (guided) layer over an anisotropic one (classic flights, but guided flights
  // from above cross it with its unstretched coefficients).
  LayerStack two = one_layer(1.3, 0.4, Spectrum(0.02), Spectrum(10.0), Spectrum(0.0), 1.1, 1.6);
  two.layers.push_back(make_layer("under", 1.5, 0.3, Spectrum(0.1), Spectrum(6.0), Spectrum(0.5)));
  const std::vector<LayerStack> stacks = {one_layer(1.0, kInfiniteThickness, Spectrum(0.01), Spectrum(5.0), Spectrum(0.0)),
                                          lambert, two};
  WalkOptions guided;
  guided.roulette_threshold = 0.0;
  guided.forced_after = 1 << 30;  // a forced roulette after the last event would scale the exit weight
  guided.guiding = 0.5;
  int checked = 0;
  for (const LayerStack& stack : stacks)
    checked += check_straight_exits(stack, incident_direction(35.0, 10.0), guided, 17, 4000,
                                    [&](const ScatterEvent&) { return &stack; });
  EXPECT_GT(checked, 1000);
}

// Guided and classic walks estimate the same BRDF: the connection estimator (sum over events of
// throughput * connection_weight towards fixed directions, what the renderer adds for a
// directional light) and the diffuse reflectance agree within 3 standard errors per channel, on
// bright isotropic stacks: coloured over a substrate, a half-space, a sheet. The guided walks'
// events are fewer: the point of guiding (measured in docs/random_walk.md). In an anisotropic
// layer guiding does nothing: the same walks bit for bit.
TEST(RandomWalkGuided, SameEstimatesAsClassicWalks) {
  LayerStack bright = coloured_stack();
  for (Layer& l : bright.layers) {
    l.sigma_a *= 0.05;
    for (PhaseLobe& lobe : l.lobes) lobe.g = Spectrum(0.0);
  }
  const LayerStack half = one_layer(1.4, kInfiniteThickness, Spectrum(0.02, 0.05, 0.2), Spectrum(10.0), Spectrum(0.0));
  LayerStack sheet = one_layer(1.3, 0.8, Spectrum(0.05), Spectrum(12.0, 9.0, 6.0), Spectrum(0.0), 1.0, 1.0);
  const glm::dvec3 wi = incident_direction(30.0, 0.0);
  const std::vector<glm::dvec3> ws = {incident_direction(20.0, 150.0), incident_direction(60.0, 0.0)};
  for (const LayerStack* stack : std::vector<const LayerStack*>{&bright, &half, &sheet}) {
    double mean[2][3][kChannels] = {}, m2[2][3][kChannels] = {};
    double events[2] = {0.0, 0.0};
    const int n = 20000;
    for (int guided = 0; guided < 2; ++guided) {
      WalkOptions ws_settings;
      ws_settings.guiding = guided ? 0.5 : 0.0;
      for (int i = 0; i < n; ++i) {
        Rng rng(23, static_cast<std::uint64_t>(i));
        Spectrum x[3];
        const WalkResult r = random_walk(*stack, wi, rng, [&](const ScatterEvent& e) {
          events[guided] += 1.0;
          for (int j = 0; j < 2; ++j) x[j] += e.throughput * connection_weight(*stack, e, ws[j]);
        }, ws_settings);
        if (r.side == WalkResult::Side::Top && r.scatter_count > 0) x[2] = r.weight;
        for (int j = 0; j < 3; ++j)
          for (int c = 0; c < kChannels; ++c) {
            mean[guided][j][c] += x[j][c] / n;
            m2[guided][j][c] += x[j][c] * x[j][c] / n;
          }
      }
    }
    for (int j = 0; j < 3; ++j)
      for (int c = 0; c < kChannels; ++c) {
        double se2 = 0.0;
        for (int g = 0; g < 2; ++g) se2 += (m2[g][j][c] - mean[g][j][c] * mean[g][j][c]) / (n - 1);
        EXPECT_NEAR(mean[1][j][c], mean[0][j][c], 3.0 * std::sqrt(se2)) << stack->name << " estimate " << j << " channel " << c;
      }
    if (std::getenv("LAMINA_TEST_VERBOSE"))
      std::printf("events per walk: classic %.1f, guided %.1f\n", events[0] / n, events[1] / n);
  }
}

TEST(RandomWalkGuided, AnisotropicLayersWalkClassically) {
  const LayerStack s = coloured_stack();  // every layer anisotropic
  WalkOptions classic;
  classic.compute_exit_pdf = true;
  WalkOptions guided = classic;
  guided.guiding = 0.7;
  for (int i = 0; i < 300; ++i) {
    Rng a(4, i), b(4, i);
    const WalkResult x = random_walk(s, incident_direction(25.0, 0.0), a, {}, classic);
    const WalkResult y = random_walk(s, incident_direction(25.0, 0.0), b, {}, guided);
    ASSERT_EQ(x.end, y.end);
    ASSERT_EQ(x.scatter_count, y.scatter_count);
    for (int c = 0; c < kChannels; ++c) ASSERT_EQ(x.weight[c], y.weight[c]);
    ASSERT_EQ(x.exit_pdf, y.exit_pdf);
  }
}

// ---- the similarity option (WalkOptions::similarity_after; approximate) ----

// Isotropic layers are their own similarity transform, so switching to it must change nothing:
// the same events, weights and ends bit for bit, on a coloured multi-layer stack with a
// substrate (catches a switch that loses the layer, the coefficients or the random stream).
TEST(RandomWalkSimilarity, IsotropicStackUnchangedBySwitching) {
  LayerStack s = coloured_stack();
  for (Layer& l : s.layers)
    for (PhaseLobe& lobe : l.lobes) lobe.g = Spectrum(0.0);
  LayerStack similar;
  similarity_transform_into(s, &similar);
  WalkOptions approx;
  approx.similarity_after = 2;  // the first event exact, the second on similar
  approx.similar = &similar;
  int switched = 0;
  for (int i = 0; i < 500; ++i) {
    const glm::dvec3 wi = incident_direction(35.0, 10.0 * i);
    std::vector<ScatterEvent> a, b;
    Rng r1(3, i), r2(3, i);
    const WalkResult x = random_walk(s, wi, r1, [&](const ScatterEvent& e) { a.push_back(e); });
    const WalkResult y = random_walk(s, wi, r2, [&](const ScatterEvent& e) { b.push_back(e); }, approx);
    ASSERT_EQ(a.size(), b.size()) << i;
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_EQ(b[k].similar, k >= 1) << i;
      for (int c = 0; c < kChannels; ++c) ASSERT_EQ(a[k].throughput[c], b[k].throughput[c]) << i;
    }
    switched += b.size() > 1;
    ASSERT_EQ(x.end, y.end) << i;
    for (int c = 0; c < kChannels; ++c) ASSERT_EQ(x.weight[c], y.weight[c]) << i;
  }
  EXPECT_GT(switched, 100);
}

// After the switch the walk samples the similar medium, and its events must be connected
// through the similar stack: as in StraightExitsMatchConnectionWeight, a grey walk that leaves
// straight from its last event has W_exit pdf / |mu_out| = throughput connection_weight, with
// both through the stack the event happened in (forward scattering, g = 0.8, switch after 2).
TEST(RandomWalkSimilarity, SimilarEventsConnectThroughTheSimilarStack) {
  LayerStack s = one_layer(1.4, 0.5, Spectrum(0.2), Spectrum(8.0), Spectrum(0.8), 1.0, 1.2);
  s.layers.push_back(make_layer("under", 1.3, 0.3, Spectrum(0.1), Spectrum(5.0), Spectrum(0.6)));
  LayerStack similar;
  similarity_transform_into(s, &similar);
  WalkOptions approx;
  approx.roulette_threshold = 0.0;
  approx.similarity_after = 2;
  approx.similar = &similar;
  const int checked = check_straight_exits(s, incident_direction(30.0, 0.0), approx, 9, 6000,
                                           [&](const ScatterEvent& last) { return last.similar ? &similar : nullptr; });
  EXPECT_GT(checked, 300);
}

// The transform: sigma_s (1 - g) per lobe and channel, g = 0, everything else kept.
TEST(RandomWalkSimilarity, TransformKeepsReducedScattering) {
  const LayerStack s = coloured_stack();
  LayerStack t;
  similarity_transform_into(s, &t);
  ASSERT_EQ(t.layers.size(), s.layers.size());
  for (std::size_t l = 0; l < s.layers.size(); ++l) {
    EXPECT_EQ(t.layers[l].sigma_a, s.layers[l].sigma_a);
    EXPECT_EQ(t.layers[l].thickness, s.layers[l].thickness);
    for (std::size_t k = 0; k < s.layers[l].lobes.size(); ++k)
      for (int c = 0; c < kChannels; ++c) {
        EXPECT_EQ(t.layers[l].lobes[k].g[c], 0.0);
        EXPECT_DOUBLE_EQ(t.layers[l].lobes[k].sigma_s[c], s.layers[l].lobes[k].sigma_s[c] * (1.0 - s.layers[l].lobes[k].g[c]));
      }
  }
  EXPECT_EQ(t.below.albedo, s.below.albedo);
}

}  // namespace
}  // namespace lamina
