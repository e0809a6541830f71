// Piecewise-constant distributions: exact pmf/pdf, zero bins never chosen, chi-square of the
// samples against the stated density.
#include "renderer/render/distribution.h"

#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "materials/base/sampling.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

TEST(Distribution1D, PmfAndPdfAreTheNormalisedValues) {
  const Distribution1D d({1.0, 0.0, 3.0, 4.0});
  EXPECT_DOUBLE_EQ(d.integral(), 8.0 / 4.0);
  EXPECT_DOUBLE_EQ(d.pmf(0), 1.0 / 8.0);
  EXPECT_DOUBLE_EQ(d.pmf(1), 0.0);
  EXPECT_DOUBLE_EQ(d.pmf(3), 0.5);
  EXPECT_DOUBLE_EQ(d.pdf(0.6), 3.0 / 2.0);  // bin 2: func / integral
  EXPECT_DOUBLE_EQ(d.pdf(0.3), 0.0);
  EXPECT_EQ(d.pdf(1.5), 0.0);
  EXPECT_THROW(Distribution1D({1.0, -1.0}), std::invalid_argument);
  EXPECT_THROW(Distribution1D({1.0, std::nan("")}), std::invalid_argument);
  EXPECT_THROW(Distribution1D(std::vector<double>{}), std::invalid_argument);
}

TEST(Distribution1D, ZeroBinsAreNeverSampledEvenAtTheEnds) {
  const Distribution1D d({0.0, 0.0, 2.0, 0.0, 1.0, 0.0});
  for (double u : {0.0, 1e-300, 0.25, 2.0 / 3.0, 0.9999999, std::nextafter(1.0, 0.0), 1.0}) {
    double pdf = 0.0;
    std::size_t bin = 99;
    const double x = d.sample_continuous(u, &pdf, &bin);
    EXPECT_TRUE(bin == 2 || bin == 4) << u;
    EXPECT_GT(pdf, 0.0);
    EXPECT_EQ(d.pdf(x), pdf) << u;
    double pmf = 0.0;
    const std::size_t i = d.sample_discrete(u, &pmf);
    EXPECT_TRUE(i == 2 || i == 4) << u;
    EXPECT_EQ(pmf, d.pmf(i));
  }
}

TEST(Distribution1D, AllZeroIsUniform) {
  const Distribution1D d({0.0, 0.0, 0.0, 0.0});
  EXPECT_EQ(d.integral(), 0.0);
  double pdf = 0.0;
  EXPECT_NEAR(d.sample_continuous(0.3, &pdf), 0.3, 1e-15);
  EXPECT_EQ(pdf, 1.0);
  EXPECT_DOUBLE_EQ(d.pmf(2), 0.25);
}

TEST(Distribution1D, ContinuousSamplesFitTheDensity) {
  // 8 bins of the function, each split in 4 cells: within a bin the density is flat, so each
  // cell expects a quarter of the bin's probability.
  const std::vector<double> f = {0.5, 2.0, 0.0, 1.0, 7.0, 0.1, 3.0, 1.5};
  const Distribution1D d(f);
  constexpr int kCells = 32, kSamples = 100000;
  std::vector<double> observed(kCells, 0.0), expected(kCells, 0.0);
  double total = 0.0;
  for (double v : f) total += v;
  for (int c = 0; c < kCells; ++c) expected[c] = kSamples * f[c / 4] / total / 4.0;
  for (int i = 0; i < kSamples; ++i) {
    Rng rng(11, i);
    double pdf;
    const double x = d.sample_continuous(rng.uniform(), &pdf);
    observed[std::min(static_cast<int>(x * kCells), kCells - 1)] += 1.0;
  }
  {
    const test::ChiSquareResult r = test::chi_square_test(observed, expected);
    EXPECT_GT(r.p_value, 1e-3) << r.describe();
  }
}

TEST(Distribution2D, SamplesFitAndPdfMatches) {
  // 4 x 3 function with a zero row and a zero cell.
  const std::vector<double> f = {1.0, 2.0, 0.0, 4.0,  //
                                 0.0, 0.0, 0.0, 0.0,  //
                                 5.0, 0.5, 3.0, 1.0};
  const Distribution2D d(f, 4, 3);
  double total = 0.0;
  for (double v : f) total += v;
  EXPECT_DOUBLE_EQ(d.integral(), total / 12.0);
  constexpr int kSamples = 100000;
  std::vector<double> observed(12, 0.0), expected(12, 0.0);
  for (int c = 0; c < 12; ++c) expected[c] = kSamples * f[c] / total;
  for (int i = 0; i < kSamples; ++i) {
    Rng rng(12, i);
    double pdf;
    std::size_t iu, iv;
    const glm::dvec2 uv = d.sample({rng.uniform(), rng.uniform()}, &pdf, &iu, &iv);
    ASSERT_EQ(d.pdf(uv), pdf);
    ASSERT_DOUBLE_EQ(pdf, f[iv * 4 + iu] / d.integral());
    observed[iv * 4 + iu] += 1.0;
  }
  {
    const test::ChiSquareResult r = test::chi_square_test(observed, expected);
    EXPECT_GT(r.p_value, 1e-3) << r.describe();
  }
}

}  // namespace
}  // namespace lamina
