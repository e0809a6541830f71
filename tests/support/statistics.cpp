#include "tests/support/statistics.h"

#include <limits>
#include <sstream>

namespace lamina::test {

namespace {

// ln Gamma(a) P(a, x) series: sum_n x^n / (a (a+1) ... (a+n)).
double gamma_p_series(double a, double x) {
  double ap = a, term = 1.0 / a, sum = term;
  for (int n = 0; n < 10000; ++n) {
    ap += 1.0;
    term *= x / ap;
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Q(a, x) by the continued fraction 1/(x+1-a- 1(1-a)/(x+3-a- 2(2-a)/(x+5-a- ...))), modified
// Lentz's method.
double gamma_q_continued_fraction(double a, double x) {
  const double tiny = std::numeric_limits<double>::min() / std::numeric_limits<double>::epsilon();
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 10000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

double regularized_gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  if (x < a + 1.0) return 1.0 - gamma_p_series(a, x);
  return gamma_q_continued_fraction(a, x);
}

double chi_square_p_value(double chi2, int dof) { return regularized_gamma_q(0.5 * dof, 0.5 * chi2); }

std::string ChiSquareResult::describe() const {
  std::ostringstream os;
  os << "chi2 = " << chi2 << " with " << dof << " dof (" << bins << " bins), p = " << p_value;
  return os.str();
}

ChiSquareResult chi_square_test(const std::vector<double>& observed, const std::vector<double>& expected,
                                double min_expected, int fitted_parameters) {
  std::vector<double> obs, exp;
  double o = 0.0, e = 0.0;
  for (std::size_t i = 0; i < observed.size(); ++i) {
    o += observed[i];
    e += expected[i];
    if (e >= min_expected) {
      obs.push_back(o);
      exp.push_back(e);
      o = e = 0.0;
    }
  }
  if (e > 0.0 || o > 0.0) {
    if (exp.empty()) {
      obs.push_back(o);
      exp.push_back(e);
    } else {
      obs.back() += o;
      exp.back() += e;
    }
  }
  ChiSquareResult r;
  r.bins = static_cast<int>(obs.size());
  r.dof = r.bins - 1 - fitted_parameters;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    if (exp[i] <= 0.0) {
      if (obs[i] > 0.0) {
        r.chi2 = std::numeric_limits<double>::infinity();
        r.p_value = 0.0;
        return r;
      }
      continue;
    }
    const double d = obs[i] - exp[i];
    r.chi2 += d * d / exp[i];
  }
  r.p_value = r.dof > 0 ? chi_square_p_value(r.chi2, r.dof) : 1.0;
  return r;
}

::testing::AssertionResult WithinKSigma(double estimate, double expected, double standard_error, double k,
                                        double floor) {
  const double diff = std::abs(estimate - expected);
  if (std::isfinite(estimate) && diff <= k * standard_error + floor) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "estimate " << estimate << " vs expected " << expected << ": |diff| "
                                       << diff << " = " << (standard_error > 0 ? diff / standard_error : INFINITY)
                                       << " standard errors (" << standard_error << "), allowed " << k
                                       << (floor > 0 ? " plus floor " : "") << (floor > 0 ? std::to_string(floor) : "");
}

}  // namespace lamina::test
