// Cross-check of two independent derivations: the analytic first order (materials/analytic/first_order)
// against the random walk's exits after exactly one scattering event (materials/walk/random_walk),
// binned in equal-solid-angle bins. Built only when the walk is present (see CMakeLists.txt).
//
// Bin value: the walk's exits with scatter_count == 1 landing in bin B estimate the power
// P(B) = int_B f1(wi, w) |cos theta| dw per unit incident power; the analytic side integrates
// first_order_bsdf over B by 8 x 8 Gauss-Legendre (error far below the noise).
// Tolerance: 5 standard errors. With ~1300 comparisons a family-wise false-alarm rate of 1e-3
// needs |z| < 4.95 per comparison (Bonferroni, normal approximation); the seeds are fixed. The
// standard error is the sample one, floored by sqrt(w_mean P / N) (w_mean: the mean weight of
// single-scattering exits; a bin with expected hit count P/w_mean has at least that Poisson
// noise), so that bins with few hits are not judged by a noisy variance estimate.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "materials/analytic/first_order.h"
#include "materials/walk/random_walk.h"
#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

void compare_single_scattering(const LayerStack& s, double theta_i_deg, int n, std::uint64_t seed) {
  const int K = 5, M = 6;
  const double ti = theta_i_deg * kPi / 180;
  const glm::dvec3 wi{std::sin(ti), 0.0, std::cos(ti)};
  std::vector<Spectrum> sum(2 * K * M), sum2(2 * K * M);
  Spectrum side_sum[2], side_sum2[2];  // totals R1 and T1: one number each, far less noisy
  double w_sum = 0, hits = 0;
  for (int i = 0; i < n; ++i) {
    Rng rng(seed, i);
    const WalkResult r = random_walk(s, wi, rng);
    if (r.scatter_count != 1 || r.side == WalkResult::Side::None) continue;
    const glm::dvec3 d = r.direction;
    const int side = d.z > 0 ? 0 : 1;
    const int k = std::min(K - 1, static_cast<int>(std::abs(d.z) * K));
    double phi = std::atan2(d.y, d.x);
    if (phi < 0) phi += 2 * kPi;
    const int m = std::min(M - 1, static_cast<int>(phi / (2 * kPi) * M));
    const int b = (side * K + k) * M + m;
    sum[b] += r.weight;
    sum2[b] += r.weight * r.weight;
    side_sum[side] += r.weight;
    side_sum2[side] += r.weight * r.weight;
    w_sum += r.weight.average();
    hits += 1;
  }
  ASSERT_GT(hits, 0);
  const double w_mean = w_sum / hits;
  double xm[8], wm[8], xp[8], wp[8];
  Spectrum side_P[2];
  for (int side = 0; side < 2; ++side)
    for (int k = 0; k < K; ++k)
      for (int m = 0; m < M; ++m) {
        Spectrum P;
        gauss_legendre(8, double(k) / K, double(k + 1) / K, xm, wm);
        gauss_legendre(8, 2 * kPi * m / M, 2 * kPi * (m + 1) / M, xp, wp);
        for (int a = 0; a < 8; ++a)
          for (int c = 0; c < 8; ++c) {
            const double mu = xm[a], st = std::sqrt((1 - mu) * (1 + mu));
            const glm::dvec3 wo{st * std::cos(xp[c]), st * std::sin(xp[c]), side == 0 ? mu : -mu};
            P += first_order_bsdf(s, wi, wo) * (wm[a] * wp[c] * mu);
          }
        const int b = (side * K + k) * M + m;
        side_P[side] += P;
        for (int c = 0; c < kChannels; ++c) {
          const double mean = sum[b][c] / n;
          const double se_sample = std::sqrt(std::max(0.0, sum2[b][c] / n - mean * mean) / n);
          const double se = std::max(se_sample, std::sqrt(w_mean * P[c] / n));
          EXPECT_NEAR(mean, P[c], 5 * se + 1e-15)
              << "theta_i " << theta_i_deg << " side " << side << " k " << k << " m " << m << " channel " << c;
        }
      }
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < kChannels; ++c) {
      const double mean = side_sum[side][c] / n;
      const double se = std::sqrt(std::max(0.0, side_sum2[side][c] / n - mean * mean) / n);
      EXPECT_NEAR(mean, side_P[side][c], 5 * se + 1e-15)
          << "total, theta_i " << theta_i_deg << " side " << side << " channel " << c << " (" << (mean - side_P[side][c]) / se << " sigma)";
    }
}

LayerStack parse(const char* json) { return parse_stack_json(json, "test"); }

TEST(FirstOrderVsWalk, MismatchedSlabForwardScattering) {
  // A 1.5 slab in air with strong forward scattering: much of the single scattering reaches the
  // outside only after internal (often total) reflections.
  const LayerStack s = parse(R"({"lamina_material": 1, "layers": [{"ior": 1.5, "thickness": 0.1,
      "sigma_a": [0.5, 3, 0], "sigma_s": [15, 8, 30], "g": [0.3, 0.8, -0.2]}]})");
  compare_single_scattering(s, 40, 150000, 1);
  compare_single_scattering(s, 75, 150000, 2);
}

TEST(FirstOrderVsWalk, ThreeLayersComposite) {
  const LayerStack s = parse(R"({"lamina_material": 1, "above_ior": 1.0, "layers": [
      {"ior": 1.3, "thickness": 0.05, "sigma_a": 0.5, "sigma_s": [15, 8, 30], "g": [0.3, 0.5, -0.2]},
      {"ior": 1.6, "thickness": 0.08, "components": [
        {"fraction": 0.5, "sigma_a": [0.4, 2, 6], "sigma_s": 40, "g": 0},
        {"fraction": 0.5, "sigma_a": 0, "sigma_s": [10, 20, 4], "g": [0.85, -0.4, 0.6]}]},
      {"ior": 1.45, "thickness": 0.2, "sigma_a": 0.1, "sigma_s": 4, "g": 0.7}],
      "below": {"ior": 1.2}})");
  compare_single_scattering(s, 40, 150000, 3);
}

TEST(FirstOrderVsWalk, LambertSubstrate) {
  const LayerStack s = parse(R"({"lamina_material": 1, "layers": [
      {"ior": 1.4, "thickness": 0.1, "sigma_a": 1.0, "sigma_s": 10, "g": 0.5},
      {"ior": 1.3, "thickness": 0.05, "sigma_a": [2, 0, 5], "sigma_s": 3, "g": -0.3}],
      "below": {"lambert": [0.6, 0.3, 0.9]}})");
  compare_single_scattering(s, 60, 150000, 4);
}

}  // namespace
}  // namespace lamina
