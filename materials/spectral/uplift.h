// From an RGB colour to a smooth spectrum (RGB "uplifting"), for the spectral renderer: Mallett
// and Yuksel (2019), "Spectral primary decomposition for rendering with sRGB reflectance" (EGSR).
// A linear Rec. 709 colour (r, g, b) becomes S(lambda) = r B_r(lambda) + g B_g(lambda) +
// b B_b(lambda) with their three published basis spectra (uplift_data.cpp names the source).
// The basis is non-negative and sums to 1 at every wavelength, so a reflectance in [0, 1]^3
// uplifts into [0, 1] at every wavelength (energy conserving) and a grey g to the flat g; lit by
// D65 and seen by the CIE 1931 observer, S has the colour (r, g, b) again (docs/spectral.md,
// "Spectral rendering", has the round trip's error). Being linear, the uplift of a texture's
// filtered colour is the filtered uplift.
#pragma once

#include <array>

#include "materials/base/spectrum.h"
#include "materials/spectral/tabulated_spectrum.h"

namespace lamina {

// B_r, B_g, B_b at nm (linear interpolation on the 5-nm table, 380-780 nm, held beyond it).
std::array<double, 3> rgb_basis(double nm);
// S(nm) = r B_r + g B_g + b B_b.
inline double uplift(const Spectrum& rgb, double nm) {
  const std::array<double, 3> b = rgb_basis(nm);
  return rgb[0] * b[0] + rgb[1] * b[1] + rgb[2] * b[2];
}
// The uplifted spectrum on the basis' own wavelengths.
TabulatedSpectrum uplifted(const Spectrum& rgb);

}  // namespace lamina
