// Statistical helpers for tests of Monte Carlo estimators and samplers. A test that uses them
// can fail: tolerances come from standard errors and p-values, never from tuning.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace lamina::test {

// Regularised upper incomplete gamma function Q(a, x) = Gamma(a, x)/Gamma(a), a > 0, x >= 0:
// series for x < a + 1, Lentz continued fraction otherwise (Numerical Recipes 3rd ed. 6.2).
// Accurate to ~1e-14 relative.
double regularized_gamma_q(double a, double x);

// P(X >= chi2) for X chi-square distributed with dof degrees of freedom: Q(dof/2, chi2/2).
double chi_square_p_value(double chi2, int dof);

struct ChiSquareResult {
  double chi2 = 0.0;
  int dof = 0;            // bins used (after merging) minus 1 minus fitted_parameters
  int bins = 0;           // bins after merging
  double p_value = 1.0;
  std::string describe() const;
};

// Pearson's chi-square goodness of fit of observed counts against expected counts (the same
// total). Adjacent bins are merged (in order) until each has an expected count >= min_expected
// (5 by the usual rule, so the chi-square approximation holds); a trailing bin below it is merged
// into the previous one. Bins with expected == 0 and observed > 0 give p = 0.
ChiSquareResult chi_square_test(const std::vector<double>& observed, const std::vector<double>& expected,
                                double min_expected = 5.0, int fitted_parameters = 0);

// Mean and standard error of the mean of a stream of samples (Welford's update, numerically
// stable for long runs).
class RunningStats {
 public:
  void add(double x) {
    ++n_;
    const double d = x - mean_;
    mean_ += d / static_cast<double>(n_);
    m2_ += d * (x - mean_);
  }
  std::uint64_t count() const { return n_; }
  double mean() const { return mean_; }
  double variance() const { return n_ > 1 ? m2_ / static_cast<double>(n_ - 1) : 0.0; }
  double standard_error() const { return n_ > 1 ? std::sqrt(variance() / static_cast<double>(n_)) : 0.0; }

 private:
  std::uint64_t n_ = 0;
  double mean_ = 0.0, m2_ = 0.0;
};

// |estimate - expected| <= k * standard_error (+ an absolute floor for round-off, default 0).
// k = 4 gives a false-alarm rate of 6e-5 per comparison for a normal estimator.
::testing::AssertionResult WithinKSigma(double estimate, double expected, double standard_error,
                                        double k = 4.0, double floor = 0.0);

}  // namespace lamina::test
