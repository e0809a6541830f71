#include "materials/spectral/uplift.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "materials/spectral/tables.h"

namespace lamina {

using spectral_tables::kMallett2019;
using spectral_tables::kMallett2019Rows;

std::array<double, 3> rgb_basis(double nm) {
  // The table is uniform (5 nm): the interval by division, no search.
  const double first = kMallett2019[0].nm, step = kMallett2019[1].nm - first;
  const double x = std::clamp((nm - first) / step, 0.0, static_cast<double>(kMallett2019Rows - 1));
  const int i = std::min(static_cast<int>(x), kMallett2019Rows - 2);
  const double t = x - i;
  const spectral_tables::BasisRow& a = kMallett2019[i];
  const spectral_tables::BasisRow& b = kMallett2019[i + 1];
  return {a.r + t * (b.r - a.r), a.g + t * (b.g - a.g), a.b + t * (b.b - a.b)};
}

TabulatedSpectrum uplifted(const Spectrum& rgb) {
  std::vector<double> nm, v;
  for (int i = 0; i < kMallett2019Rows; ++i) {
    const spectral_tables::BasisRow& row = kMallett2019[i];
    nm.push_back(row.nm);
    v.push_back(rgb[0] * row.r + rgb[1] * row.g + rgb[2] * row.b);
  }
  return TabulatedSpectrum(std::move(nm), std::move(v));
}

}  // namespace lamina
