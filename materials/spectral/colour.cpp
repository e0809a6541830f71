#include "materials/spectral/colour.h"

#include <vector>

#include "materials/spectral/tables.h"

namespace lamina {
namespace {

using spectral_tables::kCie1931;
using spectral_tables::kCie1931Rows;

TabulatedSpectrum column(double spectral_tables::CieRow::*member) {
  std::vector<double> nm, v;
  for (int i = 0; i < kCie1931Rows; ++i) {
    nm.push_back(kCie1931[i].nm);
    v.push_back(kCie1931[i].*member);
  }
  return TabulatedSpectrum(std::move(nm), std::move(v));
}

}  // namespace

WavelengthGrid colour_grid() { return {kCie1931[0].nm, 5.0, kCie1931Rows}; }
TabulatedSpectrum cie_x_bar() { return column(&spectral_tables::CieRow::x); }
TabulatedSpectrum cie_y_bar() { return column(&spectral_tables::CieRow::y); }
TabulatedSpectrum cie_z_bar() { return column(&spectral_tables::CieRow::z); }
TabulatedSpectrum illuminant_d65() { return column(&spectral_tables::CieRow::d65); }

Xyz reflectance_to_xyz(const TabulatedSpectrum& reflectance) {
  double x = 0.0, y = 0.0, z = 0.0, norm = 0.0;
  for (int i = 0; i < kCie1931Rows; ++i) {
    const spectral_tables::CieRow& row = kCie1931[i];
    const double lit = row.d65 * reflectance(row.nm);
    x += lit * row.x;
    y += lit * row.y;
    z += lit * row.z;
    norm += row.d65 * row.y;
  }
  return {x / norm, y / norm, z / norm};
}

Spectrum xyz_to_linear_rec709(const Xyz& xyz) {
  const auto& m = spectral_tables::kXyzToRec709;
  Spectrum rgb;
  for (int c = 0; c < 3; ++c) rgb[c] = m[c][0] * xyz.x + m[c][1] * xyz.y + m[c][2] * xyz.z;
  return rgb;
}

Spectrum reflectance_to_linear_rec709(const TabulatedSpectrum& reflectance) {
  return xyz_to_linear_rec709(reflectance_to_xyz(reflectance));
}

}  // namespace lamina
