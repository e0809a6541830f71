// From a spectrum to the colour Lamina writes: CIE 1931 2-degree tristimulus values under
// illuminant D65, then linear Rec. 709 (sRGB primaries, D65 white, no transfer curve), so that a
// perfect white reflector is (1, 1, 1) as in the RGB mode (docs/spectral.md, "Colour").
#pragma once

#include "materials/base/spectrum.h"
#include "materials/spectral/tabulated_spectrum.h"

namespace lamina {

struct Xyz {
  double x = 0.0, y = 0.0, z = 0.0;
};

// The grid of the colour tables: 360-780 nm every 5 nm (CIE 015:2018's D65 ends at 780 nm; the
// observer's weight beyond it is below 1e-4 of the total).
WavelengthGrid colour_grid();
// The tables themselves, on colour_grid().
TabulatedSpectrum cie_x_bar();
TabulatedSpectrum cie_y_bar();
TabulatedSpectrum cie_z_bar();
TabulatedSpectrum illuminant_d65();

// X = sum S R xbar / sum S ybar over colour_grid() (S = D65; likewise Y, Z): the colour of a
// reflectance or transmittance factor R lit by D65, a perfect reflector having Y = 1. The
// rectangle rule on the 5-nm grid, as colour-science's "Integration" method (CIE 015:2018, 7.1).
Xyz reflectance_to_xyz(const TabulatedSpectrum& reflectance);
// The sRGB matrix of IEC 61966-2-1: linear Rec. 709, D65 white.
Spectrum xyz_to_linear_rec709(const Xyz& xyz);
Spectrum reflectance_to_linear_rec709(const TabulatedSpectrum& reflectance);

}  // namespace lamina
