// Piecewise-constant distributions on [0,1) and [0,1)^2, for importance sampling tabulated
// functions: environment maps (environment.h) and light selection by power.
// After pbrt-v4 section A.4.2 (PiecewiseConstant1D) and A.4.7 (PiecewiseConstant2D); the
// code here is our own.
#pragma once

#include <cstddef>
#include <vector>

#include <glm/vec2.hpp>

namespace lamina {

// f is a step function with n equal bins on [0,1): f(x) = func[floor(x n)].
// The density is p(x) = f(x) / integral, integral = sum(func) / n. If every value is zero the
// distribution is uniform (p = 1) and integral() returns 0, so callers can tell.
class Distribution1D {
 public:
  Distribution1D() = default;
  // Throws std::invalid_argument if func is empty or holds a negative or non-finite value.
  explicit Distribution1D(std::vector<double> func);

  std::size_t size() const { return func_.size(); }
  double integral() const { return integral_; }
  double func(std::size_t i) const { return func_[i]; }

  // Inverts the CDF: x in [0,1) with density pdf(x); *bin (if given) receives floor(x n).
  // Never returns x inside a bin of zero value (unless all are zero).
  double sample_continuous(double u, double* pdf, std::size_t* bin = nullptr) const;
  // A bin index with probability func[i] / sum(func) (uniform if all are zero).
  std::size_t sample_discrete(double u, double* pmf) const;
  double pdf(double x) const;  // density of sample_continuous
  double pmf(std::size_t i) const;  // probability of sample_discrete

 private:
  std::size_t find_bin(double u) const;
  std::vector<double> func_;
  std::vector<double> cdf_;  // n + 1 entries, cdf_[0] = 0, cdf_[n] = 1
  double integral_ = 0.0;
};

// f(u, v) = func[iv * nu + iu] on [0,1)^2 with nu x nv bins (v indexes rows). Sampled as
// p(u, v) = p(v) p(u | v): a marginal over rows, weighted by each row's integral, then the
// conditional along the chosen row. The joint density is f(u, v) / integral.
class Distribution2D {
 public:
  Distribution2D() = default;
  Distribution2D(const std::vector<double>& func, std::size_t nu, std::size_t nv);

  double integral() const { return marginal_.integral(); }
  std::size_t nu() const { return nu_; }
  std::size_t nv() const { return nv_; }
  // (u, v) with density *pdf; *iu, *iv (if given) receive its bin.
  glm::dvec2 sample(const glm::dvec2& u, double* pdf, std::size_t* iu = nullptr, std::size_t* iv = nullptr) const;
  double pdf(const glm::dvec2& uv) const;

 private:
  std::size_t nu_ = 0, nv_ = 0;
  std::vector<Distribution1D> conditional_;  // one per row
  Distribution1D marginal_;                 // over rows, func = row integrals
};

}  // namespace lamina
