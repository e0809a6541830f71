// Henyey-Greenstein: normalisation by quadrature, the samplers by chi-square against the
// analytic CDF, the mean cosine within its standard error, and continuity at g = 0.
#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/phase/henyey_greenstein.h"
#include "materials/base/sampling.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::chi_square_test;
using test::RunningStats;
using test::WithinKSigma;

// CDF of cos(theta) under HG, derived independently of the sampler's algebra:
//   P(mu) = 2 pi int_{-1}^{mu} p = (1 - g^2)/(2g) [b^{-1/2} - 1/(1 + g)],  b = 1 + g^2 - 2 g mu.
// With (1 + g)^2 - b = 2 g (1 + mu) this is, without cancellation and valid at g = 0,
//   P(mu) = (1 - g)(1 + mu) / (sqrt(b) (1 + g + sqrt(b))).
double hg_cdf(double mu, double g) {
  const double b = g >= 0.0 ? (1 - g) * (1 - g) + 2 * g * (1 - mu) : (1 + g) * (1 + g) - 2 * g * (1 + mu);
  const double sb = std::sqrt(b);
  return (1 - g) * (1 + mu) / (sb * (1 + g + sb));
}

// mu with P(mu) = target, by bisection (monotone P).
double hg_cdf_inverse(double target, double g) {
  double lo = -1, hi = 1;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (hg_cdf(mid, g) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Bin edges equal in CDF (so every bin expects N / bins samples).
std::vector<double> equal_probability_edges(double g, int bins) {
  std::vector<double> e(bins + 1);
  e[0] = -1;
  e[bins] = 1;
  for (int j = 1; j < bins; ++j) e[j] = hg_cdf_inverse(double(j) / bins, g);
  return e;
}

int bin_of(const std::vector<double>& edges, double mu) {
  const int k = static_cast<int>(std::upper_bound(edges.begin(), edges.end(), mu) - edges.begin()) - 1;
  return std::clamp(k, 0, static_cast<int>(edges.size()) - 2);
}

const double kGs[] = {-0.9, -0.3, 0.0, 1e-6, 0.5, 0.95, 0.999};

TEST(HenyeyGreensteinStats, CdfIsTheIntegralOfThePdf) {
  // Ties hg_cdf to henyey_greenstein (central differences, error O(h^2) ~ 1e-8 relative).
  for (double g : {-0.9, -0.3, 0.0, 0.5, 0.9}) {
    EXPECT_NEAR(hg_cdf(-1, g), 0.0, 1e-16);
    EXPECT_NEAR(hg_cdf(1, g), 1.0, 1e-15);
    for (double mu : {-0.9, -0.2, 0.3, 0.8}) {
      const double h = 1e-4;
      const double deriv = (hg_cdf(mu + h, g) - hg_cdf(mu - h, g)) / (2 * h);
      const double pdf = 2 * kPi * henyey_greenstein(mu, g);
      EXPECT_NEAR(deriv, pdf, 1e-6 * pdf) << g << " " << mu;
    }
  }
}

TEST(HenyeyGreensteinStats, NormalisedUpToExtremeG) {
  // 2 pi int_{-1}^{1} p dmu = 1 by composite 16-point Gauss-Legendre on panels graded
  // geometrically towards both ends (the lobe of g = 0.9999 has width (1-g)^2/(2g) ~ 5e-9 in
  // 1 - mu), down to 2^-50, plus the two end panels. Each panel sees an integrand that varies by
  // a bounded factor, so the rule is accurate to ~1e-13; compared with 1e-10.
  std::vector<double> x(16), w(16);
  gauss_legendre(16, 0.0, 1.0, x.data(), w.data());
  std::vector<double> cuts{-1.0, 1.0};
  for (int k = 0; k <= 50; ++k) {
    cuts.push_back(-1.0 + std::ldexp(1.0, -k));
    cuts.push_back(1.0 - std::ldexp(1.0, -k));
  }
  std::sort(cuts.begin(), cuts.end());
  cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
  for (double g : {-0.9999, -0.99, -0.9, -0.5, -1e-9, 0.0, 1e-9, 0.5, 0.9, 0.99, 0.9999}) {
    double sum = 0;
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
      const double a = cuts[i], b = cuts[i + 1];
      for (int j = 0; j < 16; ++j) sum += (b - a) * w[j] * 2 * kPi * henyey_greenstein(a + (b - a) * x[j], g);
    }
    EXPECT_NEAR(sum, 1.0, 1e-10) << "g = " << g;
  }
}

TEST(HenyeyGreensteinStats, CosineSamplerChiSquare) {
  // 100 bins of equal probability, 200000 samples: 2000 expected per bin. A correct sampler
  // passes with probability 0.999 per g; the seed is fixed, so the outcome is reproducible.
  const int bins = 100, n = 200000;
  for (double g : kGs) {
    const std::vector<double> edges = equal_probability_edges(g, bins);
    std::vector<double> obs(bins, 0.0), expected(bins, double(n) / bins);
    Rng rng(12345, static_cast<std::uint64_t>(std::llround((g + 2) * 1e6)));
    for (int i = 0; i < n; ++i) obs[bin_of(edges, sample_henyey_greenstein_cos(g, rng.uniform()))] += 1;
    const auto r = chi_square_test(obs, expected);
    EXPECT_GT(r.p_value, 1e-3) << "g = " << g << ": " << r.describe();
  }
}

TEST(HenyeyGreensteinStats, ChiSquareDetectsAWrongSampler) {
  // The test above can fail: sampling g = 0.5 against the bins of g = 0.49 is rejected.
  const int bins = 100, n = 200000;
  const std::vector<double> edges = equal_probability_edges(0.49, bins);
  std::vector<double> obs(bins, 0.0), expected(bins, double(n) / bins);
  Rng rng(1, 2);
  for (int i = 0; i < n; ++i) obs[bin_of(edges, sample_henyey_greenstein_cos(0.5, rng.uniform()))] += 1;
  EXPECT_LT(chi_square_test(obs, expected).p_value, 1e-6);
}

TEST(HenyeyGreensteinStats, DirectionSamplerChiSquareInCosineAndAzimuth) {
  // Joint 20 x 20 bins: cos(theta) to d in equal-probability bins, the azimuth about d (in a
  // basis built here, not the sampler's) in 20 uniform bins; 200000 samples, 500 per bin.
  const int nb = 20, n = 200000;
  const std::vector<glm::dvec3> dirs = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, glm::normalize(glm::dvec3(0.3, -0.5, 0.8)),
                                        glm::normalize(glm::dvec3(-1e-9, 1e-9, -1.0))};
  int case_index = 0;
  for (double g : {-0.7, 0.0, 0.5, 0.95}) {
    const std::vector<double> edges = equal_probability_edges(g, nb);
    for (const glm::dvec3& d : dirs) {
      const glm::dvec3 a = std::abs(d.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
      const glm::dvec3 t = glm::normalize(a - glm::dot(a, d) * d), b = glm::cross(d, t);
      std::vector<double> obs(nb * nb, 0.0), expected(nb * nb, double(n) / (nb * nb));
      Rng rng(99, case_index++);
      double worst_norm = 0;
      for (int i = 0; i < n; ++i) {
        const double u1 = rng.uniform(), u2 = rng.uniform();
        const glm::dvec3 w = sample_henyey_greenstein(d, g, u1, u2);
        worst_norm = std::max(worst_norm, std::abs(glm::dot(w, w) - 1));
        double phi = std::atan2(glm::dot(w, b), glm::dot(w, t));
        if (phi < 0) phi += 2 * kPi;
        const int ip = std::min(nb - 1, static_cast<int>(phi / (2 * kPi) * nb));
        obs[bin_of(edges, glm::dot(w, d)) * nb + ip] += 1;
      }
      EXPECT_LT(worst_norm, 1e-14);
      const auto r = chi_square_test(obs, expected);
      EXPECT_GT(r.p_value, 1e-3) << "g = " << g << " d = " << d.x << "," << d.y << "," << d.z << ": " << r.describe();
    }
  }
}

TEST(HenyeyGreensteinStats, SampledMeanCosineIsG) {
  // E[mu] = g; the standard error is estimated from the samples (Var = (1 - g^2)/3 for HG).
  const int n = 1000000;
  for (double g : kGs) {
    RunningStats s;
    Rng rng(2024, static_cast<std::uint64_t>(std::llround((g + 2) * 1e6)));
    for (int i = 0; i < n; ++i) s.add(sample_henyey_greenstein_cos(g, rng.uniform()));
    EXPECT_TRUE(WithinKSigma(s.mean(), g, s.standard_error(), 4.0)) << "g = " << g;
    // The second moment too. HG has Legendre moments E[P_l(mu)] = g^l, so the raw moments are
    // m1 = g, m2 = (1 + 2 g^2)/3, m3 = (3 g + 2 g^3)/5, m4 = (7 + 20 g^2 + 8 g^4)/35, the variance
    // (1 - g^2)/3, and the sample variance has standard error sqrt((mu4 - var^2)/n) with the
    // central fourth moment mu4 = m4 - 4 m3 m1 + 6 m2 m1^2 - 3 m1^4.
    const double m1 = g, m2 = (1 + 2 * g * g) / 3, m3 = (3 * g + 2 * g * g * g) / 5,
                 m4 = (7 + 20 * g * g + 8 * g * g * g * g) / 35;
    const double var = m2 - m1 * m1;
    const double mu4 = m4 - 4 * m3 * m1 + 6 * m2 * m1 * m1 - 3 * m1 * m1 * m1 * m1;
    EXPECT_TRUE(WithinKSigma(s.variance(), var, std::sqrt((mu4 - var * var) / n), 5.0)) << "g = " << g;
  }
}

TEST(HenyeyGreensteinStats, ContinuousThroughZero) {
  for (double g : {1e-9, -1e-9}) {
    for (double mu : {-1.0, -0.5, 0.0, 0.7, 1.0}) {
      // p = (1 + 3 g mu + O(g^2)) / (4 pi)
      EXPECT_NEAR(henyey_greenstein(mu, g), kInv4Pi * (1 + 3 * g * mu), 1e-15 * kInv4Pi);
    }
    for (double u : {0.0, 0.1, 0.37, 0.5, 0.9, 1.0 - 1e-16}) {
      // mu(g, u) = xi + (3/2) g (1 - xi^2) + O(g^2), xi = 2u - 1 (expanding the sampler's exact form)
      const double xi = 2 * u - 1;
      const double s0 = sample_henyey_greenstein_cos(0.0, u), sg = sample_henyey_greenstein_cos(g, u);
      EXPECT_NEAR(s0, xi, 1e-16);
      EXPECT_NEAR(sg - s0, 1.5 * g * (1 - xi * xi), 1e-15) << g << " " << u;
    }
  }
}

}  // namespace
}  // namespace lamina
