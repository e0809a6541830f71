// A spectrum given by samples at increasing wavelengths (nm), read between them by linear
// interpolation. Outside the tabulated range it holds its end values: a chromophore table that
// stops at 450 nm gives its 450-nm value below (docs/spectral.md says which tables do).
#pragma once

#include <vector>

#include "materials/spectral/wavelength_grid.h"

namespace lamina {

class TabulatedSpectrum {
 public:
  TabulatedSpectrum() = default;
  // Throws std::invalid_argument unless both have the same non-zero length, the wavelengths
  // increase strictly and every number is finite.
  TabulatedSpectrum(std::vector<double> nm, std::vector<double> values);
  // The same value at every wavelength.
  static TabulatedSpectrum constant(double value);

  double operator()(double nm) const;
  std::vector<double> sample(const WavelengthGrid& grid) const;

  bool covers(double nm) const { return nm >= nm_.front() && nm <= nm_.back(); }
  const std::vector<double>& wavelengths() const { return nm_; }
  const std::vector<double>& values() const { return values_; }

  // Pointwise a * this + b * other, on the union of both sets of wavelengths.
  TabulatedSpectrum combined(double a, const TabulatedSpectrum& other, double b) const;

 private:
  std::vector<double> nm_{0.0};
  std::vector<double> values_{0.0};
};

}  // namespace lamina
