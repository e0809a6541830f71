// The colour (linear Rec. 709) of a reflectance spectrum lit by D65, as the spectral renderer's
// film integrates it (materials/spectral/sampled_wavelengths.h): over 360-830 nm, the CIE tables
// read as TabulatedSpectrum reads them (linear between nodes, held beyond), by the trapezoid rule
// on 0.05-nm steps. An independent route for the tests of the spectral mode.
#pragma once

#include "materials/spectral/colour.h"
#include "materials/spectral/sampled_wavelengths.h"

namespace lamina::test {

template <class Reflectance>
Spectrum colour_by_quadrature(const Reflectance& reflectance) {
  const TabulatedSpectrum d65 = illuminant_d65(), x = cie_x_bar(), y = cie_y_bar(), z = cie_z_bar();
  const int n = 9400;
  const double h = (kSpectralLastNm - kSpectralFirstNm) / n;
  Xyz sum;
  double norm = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double nm = kSpectralFirstNm + i * h, wt = (i == 0 || i == n) ? 0.5 * h : h;
    const double lit = d65(nm) * reflectance(nm) * wt;
    sum.x += lit * x(nm);
    sum.y += lit * y(nm);
    sum.z += lit * z(nm);
    norm += d65(nm) * y(nm) * wt;
  }
  return xyz_to_linear_rec709({sum.x / norm, sum.y / norm, sum.z / norm});
}

}  // namespace lamina::test
