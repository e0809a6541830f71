#include "materials/spectral/tabulated_spectrum.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

namespace lamina {

TabulatedSpectrum::TabulatedSpectrum(std::vector<double> nm, std::vector<double> values)
    : nm_(std::move(nm)), values_(std::move(values)) {
  if (nm_.empty() || nm_.size() != values_.size())
    throw std::invalid_argument("spectrum: needs as many values as wavelengths, at least one");
  for (size_t i = 0; i < nm_.size(); ++i) {
    if (!std::isfinite(nm_[i]) || !std::isfinite(values_[i]))
      throw std::invalid_argument("spectrum: sample " + std::to_string(i) + " is not finite");
    if (i > 0 && !(nm_[i] > nm_[i - 1]))
      throw std::invalid_argument("spectrum: wavelengths must increase (sample " + std::to_string(i) + ")");
  }
}

TabulatedSpectrum TabulatedSpectrum::constant(double value) { return TabulatedSpectrum({0.0}, {value}); }

double TabulatedSpectrum::operator()(double nm) const {
  if (nm <= nm_.front()) return values_.front();
  if (nm >= nm_.back()) return values_.back();
  const size_t hi = static_cast<size_t>(std::upper_bound(nm_.begin(), nm_.end(), nm) - nm_.begin());
  const size_t lo = hi - 1;
  const double t = (nm - nm_[lo]) / (nm_[hi] - nm_[lo]);
  return values_[lo] + t * (values_[hi] - values_[lo]);
}

std::vector<double> TabulatedSpectrum::sample(const WavelengthGrid& grid) const {
  std::vector<double> out(static_cast<size_t>(grid.count));
  for (int i = 0; i < grid.count; ++i) out[static_cast<size_t>(i)] = (*this)(grid.at(i));
  return out;
}

TabulatedSpectrum TabulatedSpectrum::combined(double a, const TabulatedSpectrum& other, double b) const {
  std::vector<double> nm;
  std::set_union(nm_.begin(), nm_.end(), other.nm_.begin(), other.nm_.end(), std::back_inserter(nm));
  std::vector<double> values(nm.size());
  for (size_t i = 0; i < nm.size(); ++i) values[i] = a * (*this)(nm[i]) + b * other(nm[i]);
  return TabulatedSpectrum(std::move(nm), std::move(values));
}

}  // namespace lamina
