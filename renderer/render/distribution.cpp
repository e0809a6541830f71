// Piecewise-constant distributions (see distribution.h).
#include "renderer/render/distribution.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lamina {
namespace {

// The largest double below 1: the CDF inversion needs u < 1.
constexpr double kOneMinusEpsilon = 0x1.fffffffffffffp-1;

double clamp_unit(double u) { return std::min(std::max(u, 0.0), kOneMinusEpsilon); }

}  // namespace

Distribution1D::Distribution1D(std::vector<double> func) : func_(std::move(func)) {
  if (func_.empty()) throw std::invalid_argument("Distribution1D: no values");
  const std::size_t n = func_.size();
  for (std::size_t i = 0; i < n; ++i)
    if (!(func_[i] >= 0.0) || !std::isfinite(func_[i]))
      throw std::invalid_argument("Distribution1D: value " + std::to_string(i) + " is negative or not finite");
  // Running sum of the bin integrals func[i] / n (the CDF before normalisation).
  cdf_.assign(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) cdf_[i + 1] = cdf_[i] + func_[i] / static_cast<double>(n);
  integral_ = cdf_[n];
  if (integral_ > 0.0) {
    for (double& c : cdf_) c /= integral_;
  } else {
    for (std::size_t i = 0; i <= n; ++i) cdf_[i] = static_cast<double>(i) / static_cast<double>(n);
  }
  cdf_[n] = 1.0;  // exactly, whatever the rounding
}

// The largest i in [0, n) with cdf[i] <= u. For u < 1 this skips bins of zero width: if
// cdf[i] == cdf[i + 1] <= u, then i + 1 also qualifies.
std::size_t Distribution1D::find_bin(double u) const {
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);  // first cdf > u
  const std::size_t i = static_cast<std::size_t>(it - cdf_.begin());
  return std::min(i == 0 ? 0 : i - 1, func_.size() - 1);
}

double Distribution1D::sample_continuous(double u, double* pdf, std::size_t* bin) const {
  u = clamp_unit(u);
  const std::size_t i = find_bin(u);
  const double width = cdf_[i + 1] - cdf_[i];
  // Linear inversion inside the bin, where the CDF is linear.
  double du = width > 0.0 ? (u - cdf_[i]) / width : 0.0;
  du = std::min(std::max(du, 0.0), kOneMinusEpsilon);
  const double n = static_cast<double>(func_.size());
  if (pdf) *pdf = integral_ > 0.0 ? func_[i] / integral_ : 1.0;
  if (bin) *bin = i;
  // Keep x inside bin i despite rounding (floor(x n) == i), so pdf(x) agrees with *pdf.
  double x = (static_cast<double>(i) + du) / n;
  while (x > 0.0 && x * n >= static_cast<double>(i) + 1.0) x = std::nextafter(x, 0.0);
  return x;
}

std::size_t Distribution1D::sample_discrete(double u, double* pmf_out) const {
  const std::size_t i = find_bin(clamp_unit(u));
  if (pmf_out) *pmf_out = pmf(i);
  return i;
}

double Distribution1D::pdf(double x) const {
  if (!(x >= 0.0 && x <= 1.0)) return 0.0;
  const std::size_t i = std::min(static_cast<std::size_t>(x * static_cast<double>(func_.size())), func_.size() - 1);
  return integral_ > 0.0 ? func_[i] / integral_ : 1.0;
}

double Distribution1D::pmf(std::size_t i) const {
  if (i >= func_.size()) return 0.0;
  return cdf_[i + 1] - cdf_[i];
}

Distribution2D::Distribution2D(const std::vector<double>& func, std::size_t nu, std::size_t nv) : nu_(nu), nv_(nv) {
  if (nu == 0 || nv == 0 || func.size() != nu * nv)
    throw std::invalid_argument("Distribution2D: size does not match nu * nv");
  std::vector<double> row_integrals(nv);
  conditional_.reserve(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    conditional_.emplace_back(std::vector<double>(func.begin() + v * nu, func.begin() + (v + 1) * nu));
    row_integrals[v] = conditional_.back().integral();
  }
  marginal_ = Distribution1D(std::move(row_integrals));
}

// p(u, v) = p(v) p(u | v) = (I_v / I) (f(u, v) / I_v) = f(u, v) / I, with I_v the row integral
// and I the total (pbrt-v4 eq. A.17-A.18).
glm::dvec2 Distribution2D::sample(const glm::dvec2& u, double* pdf, std::size_t* iu, std::size_t* iv) const {
  std::size_t row = 0, col = 0;
  const double v = marginal_.sample_continuous(u.y, nullptr, &row);
  const double x = conditional_[row].sample_continuous(u.x, nullptr, &col);
  // p(v) p(u | v) equals f / I; computed as pdf() does, so the two agree to the last bit.
  if (pdf) *pdf = marginal_.integral() > 0.0 ? conditional_[row].func(col) / marginal_.integral() : 1.0;
  if (iu) *iu = col;
  if (iv) *iv = row;
  return {x, v};
}

double Distribution2D::pdf(const glm::dvec2& uv) const {
  if (!(uv.x >= 0.0 && uv.x <= 1.0 && uv.y >= 0.0 && uv.y <= 1.0)) return 0.0;
  const std::size_t row = std::min(static_cast<std::size_t>(uv.y * static_cast<double>(nv_)), nv_ - 1);
  const std::size_t col = std::min(static_cast<std::size_t>(uv.x * static_cast<double>(nu_)), nu_ - 1);
  if (marginal_.integral() <= 0.0) return 1.0;  // all zero: uniform, as Distribution1D
  return conditional_[row].func(col) / marginal_.integral();
}

}  // namespace lamina
