#include "materials/base/sampling.h"

#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>

#include "tests/support/statistics.h"

namespace lamina {

// unit_circle(u) against cos and sin of 2 pi u in long double (64-bit mantissa: in double the
// reference's own argument 2 pi u is rounded by up to 4.4e-16 near u = 1, more than unit_circle,
// whose reduction is exact), at the quadrant and octant boundaries (where the reduction switches
// k) and at a million uniforms of the generator. The bound, 4e-16, is four rounding units of a
// value of magnitude 1 (the argument 2 pi r is rounded once, the polynomials a few times); an
// error of the truncated series or of a quadrant is 1e-16 to 1 and fails it.
TEST(Sampling, UnitCircleMatchesTheLibraryToRounding) {
  double worst = 0.0;
  auto check = [&](double u) {
    const glm::dvec2 a = unit_circle(u);
    const long double x = 2.0L * 3.14159265358979323846264338327950288L * static_cast<long double>(u);
    const double error = static_cast<double>(
        std::max(std::abs(a.x - std::cos(x)), std::abs(a.y - std::sin(x))));
    worst = std::max(worst, error);
    ASSERT_LE(error, 4e-16) << "u " << u;
  };
  for (int k = 0; k <= 8; ++k)
    for (double e : {-1e-16, 0.0, 1e-16, -1e-9, 1e-9}) {
      const double u = k / 8.0 + e;
      if (u >= 0.0 && u <= 1.0) check(u);
    }
  Rng rng(12, 0);
  for (int i = 0; i < 1000000; ++i) check(rng.uniform());
  std::printf("unit_circle: worst difference from cos/sin in long double %.3g\n", worst);
}

// The ziggurat's exponential variates against the exact Exp(1) distribution: 2e6 samples in
// bins of 0.04 up to 16 and one for the tail beyond (every strip of the ziggurat, the base's
// tail past r = 7.7 and the wedges' rejections are visited); chi-square p above 1e-3 (a correct
// sampler fails with probability 1e-3), and the mean within 4.5 standard errors of 1.
// The same bins reject variates 1 % too large (ExponentialSamplerChiSquareHasPower).
std::vector<double> exponential_histogram(int n, double scale, std::vector<double>* expected, double* mean) {
  constexpr double kWidth = 0.04;
  constexpr int kBins = 400;  // [0, 16), then [16, inf)
  std::vector<double> observed(kBins + 1, 0.0);
  expected->assign(kBins + 1, 0.0);
  for (int b = 0; b < kBins; ++b) (*expected)[b] = n * (std::exp(-b * kWidth) - std::exp(-(b + 1) * kWidth));
  (*expected)[kBins] = n * std::exp(-kBins * kWidth);
  Rng rng(2026, 12);
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double x = scale * sample_exponential(rng);
    EXPECT_GE(x, 0.0);
    sum += x;
    observed[std::min(kBins, static_cast<int>(x / kWidth))] += 1.0;
  }
  *mean = sum / n;
  return observed;
}

TEST(Sampling, ExponentialSamplerChiSquare) {
  const int n = 2000000;
  std::vector<double> expected;
  double mean = 0.0;
  const std::vector<double> observed = exponential_histogram(n, 1.0, &expected, &mean);
  const test::ChiSquareResult r = test::chi_square_test(observed, expected);
  EXPECT_GT(r.p_value, 1e-3) << r.describe();
  EXPECT_NEAR(mean, 1.0, 4.5 / std::sqrt(static_cast<double>(n)));  // Exp(1): standard deviation 1
  std::printf("exponential sampler: %s, mean %.5f\n", r.describe().c_str(), mean);
}

TEST(Sampling, ExponentialSamplerChiSquareHasPower) {
  std::vector<double> expected;
  double mean = 0.0;
  const std::vector<double> observed = exponential_histogram(2000000, 1.01, &expected, &mean);
  EXPECT_LT(test::chi_square_test(observed, expected).p_value, 1e-6);
}

}  // namespace lamina
