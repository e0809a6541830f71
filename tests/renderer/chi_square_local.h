// Pearson's chi-square goodness-of-fit test, local to the renderer tests until the shared
// tests/support/statistics.h (branch `analytic`) exists; then switch to that one.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

namespace lamina::test {

// Regularised upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a): the series
// for P = 1 - Q when x < a + 1, Legendre's continued fraction for Q otherwise (evaluated by the
// modified Lentz method); both converge quickly in their ranges (Abramowitz & Stegun 6.5.29,
// 6.5.31).
inline double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 10000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return 1.0 - std::exp(log_prefactor) * sum;
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 10000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(log_prefactor) * h;
}

// p-value of observed counts against expected counts (same total). Cells expected to hold
// fewer than 5 samples are pooled into one, so the chi-square approximation holds. A count in
// a cell of zero expectation returns 0 (impossible under the hypothesis).
inline double chi_square_p_value(const std::vector<double>& observed, const std::vector<double>& expected,
                                 int* dof_out = nullptr) {
  double chi2 = 0.0, pooled_obs = 0.0, pooled_exp = 0.0;
  int cells = 0;
  for (std::size_t i = 0; i < observed.size(); ++i) {
    if (expected[i] <= 0.0) {
      if (observed[i] > 0.0) return 0.0;
      continue;
    }
    if (expected[i] < 5.0) {
      pooled_obs += observed[i];
      pooled_exp += expected[i];
      continue;
    }
    chi2 += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
    ++cells;
  }
  if (pooled_exp > 0.0) {
    chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
    ++cells;
  }
  const int dof = cells - 1;  // the total is fixed
  if (dof_out) *dof_out = dof;
  if (dof < 1) return 1.0;
  return gamma_q(0.5 * dof, 0.5 * chi2);
}

}  // namespace lamina::test
