// Next-flight connections (materials/walk/next_flight_connection.h): on the same walks, the MIS
// estimator and the plain per-event connection must have the same mean (their paired difference
// within 4 of its standard errors), and the MIS one must be less noisy where the phase function
// is forward-peaked.
#include <cmath>

#include <gtest/gtest.h>

#include "materials/walk/next_flight_connection.h"
#include "materials/walk/random_walk.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

struct Paired {
  Spectrum plain_mean, plain_var, diff_mean, diff_se, nf_var;
};

// Per walk, X_plain = sum_e W_e connection_weight(e, w) and X_nf = sum_e (both techniques).
Paired run(const LayerStack& stack, const glm::dvec3& wo, const glm::dvec3& w, int walks) {
  const ExitDirection exit = prepare_exit(stack, w);
  Spectrum s_plain, s2_plain, s_diff, s2_diff, s_nf, s2_nf;
  for (int i = 0; i < walks; ++i) {
    Rng rng(77, static_cast<std::uint64_t>(i), 3);
    Rng rng_b(78, static_cast<std::uint64_t>(i), 5);
    Spectrum plain, nf;
    ScatterEvent previous;
    random_walk(stack, wo, rng, [&](const ScatterEvent& e) {
      plain += e.throughput * connection_weight(stack, e, w);
      const double u1 = rng_b.uniform(), u2 = rng_b.uniform();
      nf += next_flight_event_connection(stack, previous, e, exit, u1, u2);
      previous = e;
    });
    const Spectrum d = nf - plain;
    s_plain += plain;
    s2_plain += plain * plain;
    s_nf += nf;
    s2_nf += nf * nf;
    s_diff += d;
    s2_diff += d * d;
  }
  Paired out;
  const double n = walks;
  for (int c = 0; c < kChannels; ++c) {
    out.plain_mean[c] = s_plain[c] / n;
    out.plain_var[c] = s2_plain[c] / n - out.plain_mean[c] * out.plain_mean[c];
    const double nf_mean = s_nf[c] / n;
    out.nf_var[c] = s2_nf[c] / n - nf_mean * nf_mean;
    out.diff_mean[c] = s_diff[c] / n;
    out.diff_se[c] = std::sqrt(std::max(0.0, s2_diff[c] / n - out.diff_mean[c] * out.diff_mean[c]) / (n - 1));
  }
  return out;
}

glm::dvec3 direction(double theta_deg, double phi_deg, bool up = true) {
  const double t = theta_deg * M_PI / 180.0, p = phi_deg * M_PI / 180.0;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), up ? std::cos(t) : -std::cos(t)};
}

void expect_same_mean(const Paired& r, const char* what) {
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_GT(r.plain_mean[c], 0.0) << what << " channel " << c;
    EXPECT_LT(std::abs(r.diff_mean[c]), 4.0 * r.diff_se[c] + 1e-15)
        << what << " channel " << c << ": plain mean " << r.plain_mean[c] << ", difference " << r.diff_mean[c]
        << " +- " << r.diff_se[c];
  }
}

// Forward-peaked composite skin-like layers with channel-dependent scattering over a Lambert
// substrate: reflection, the renderer's case.
TEST(NextFlightConnection, SameMeanAndLessNoiseInForwardScatteringSkin) {
  LayerStack s = test::skin_like_stack();
  s.layers[1].lobes[0].g = Spectrum(0.8);
  const Paired r = run(s, direction(20, 0), direction(40, 180), 20000);
  expect_same_mean(r, "skin-like");
  for (int c = 0; c < kChannels; ++c)
    EXPECT_LT(r.nf_var[c], 0.8 * r.plain_var[c]) << "channel " << c << ": the MIS should remove the phase spikes";
}

// A finite slab between different media, g = 0.9: reflection and transmission (the exit below).
TEST(NextFlightConnection, SameMeanThroughAFiniteSlabBothWays) {
  const LayerStack s = test::one_layer(1.4, 0.3, Spectrum(0.1, 0.5, 1.0), Spectrum(12.0, 9.0, 6.0), Spectrum(0.9),
                                       1.0, 1.33);
  expect_same_mean(run(s, direction(30, 0), direction(60, 90), 20000), "slab, reflection");
  expect_same_mean(run(s, direction(30, 0), direction(25, 200, false), 20000), "slab, transmission");
}

// A semi-infinite layer (flights downwards never meet a boundary), viewer and light near grazing.
TEST(NextFlightConnection, SameMeanInAHalfSpaceAtGrazingAngles) {
  const LayerStack s = test::one_layer(1.33, kInfiniteThickness, Spectrum(0.05, 0.2, 0.6), Spectrum(8.0),
                                       Spectrum(0.7));
  expect_same_mean(run(s, direction(80, 0), direction(85, 120), 20000), "half-space");
}

// Where the walk does not sample by one grey HG lobe, the estimator is the plain connection.
TEST(NextFlightConnection, OnlyInSingleGreyLobeLayers) {
  LayerStack s = test::one_layer(1.4, 0.5, Spectrum(0.1), Spectrum(5.0), Spectrum(0.3, 0.5, 0.7));
  const ExitDirection exit = prepare_exit(s, direction(30, 0));
  EXPECT_FALSE(next_flight_layer(0, exit));  // g differs per channel
  s.layers[0].lobes[0].g = Spectrum(0.5);
  EXPECT_TRUE(next_flight_layer(0, prepare_exit(s, direction(30, 0))));
  EXPECT_FALSE(next_flight_layer(0, prepare_exit(s, direction(30, 0)), 0.6));  // below min_g
  EXPECT_TRUE(next_flight_layer(0, prepare_exit(s, direction(30, 0)), 0.5));
  s.layers[0].lobes[0].sigma_s = Spectrum(5.0, 0.0, 5.0);  // a channel that does not scatter
  EXPECT_FALSE(next_flight_layer(0, prepare_exit(s, direction(30, 0))));
}

}  // namespace
}  // namespace lamina
