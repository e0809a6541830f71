// The wavelengths a path of the spectral renderer carries: hero-wavelength sampling (Wilkie,
// Nawaz, Droske, Weidlich and Hanika 2014, "Hero wavelength spectral sampling", EGSR; pbrt-v4's
// SampledWavelengths). A path draws a hero wavelength and carries two companions rotated by a
// third of the sampling domain, so that Spectrum's three channels hold the path's three
// wavelengths and every part of the renderer that works per channel (the walk's hero channel
// and spectral MIS included) works on wavelengths unchanged. sampled_wavelengths.cpp has the
// derivations; docs/spectral.md, "Spectral rendering", the user's view.
#pragma once

#include <cstdint>

#include "materials/base/spectrum.h"

namespace lamina {

// The sampled range, nm.
constexpr double kSpectralFirstNm = 360.0;
constexpr double kSpectralLastNm = 830.0;

// pbrt-v4's density for visible wavelengths (SampleVisibleWavelengths, src/pbrt/util/sampling.h):
// p(lambda) proportional to 1 / cosh^2(0.0072 (lambda - 538)) on [360, 830] nm, normalised here in
// double precision; sample_visible_wavelength inverts its CDF.
double visible_wavelength_pdf(double nm);
double sample_visible_wavelength(double u);

class SampledWavelengths {
 public:
  // The hero from u in [0, 1), the companions from u + 1/3 and u + 2/3 (mod 1), each through
  // sample_visible_wavelength: each of the three is distributed with visible_wavelength_pdf.
  static SampledWavelengths from_uniform(double u);
  // Three given wavelengths in [360, 830] nm (the spectral tables' grid, renderer/layered/
  // spectral_tables.h), with the densities and weights a path drawing them would have.
  static SampledWavelengths at(double nm0, double nm1, double nm2);
  // The wavelengths of sample `sample` of pixel `pixel`: u = frac(o + sample phi), phi the golden
  // ratio's fraction, o uniform from a stream of its own keyed by (seed, pixel) (the .cpp has why).
  static SampledWavelengths for_sample(std::uint64_t seed, std::uint64_t pixel, std::uint64_t sample);

  double nm(int i) const { return nm_[i]; }
  double pdf(int i) const { return pdf_[i]; }

  // A linear Rec. 709 reflectance (or any factor of a path's throughput) at the three
  // wavelengths, uplifted (materials/spectral/uplift.h).
  Spectrum reflectance(const Spectrum& rgb) const;
  // The RGB ratio value / base (1 where base is 0) at the three wavelengths: a grey ratio as it
  // is, any other uplifted as a reflectance. How the table and lambert modes carry an RGB model's
  // relative change (a texture-driven parameter's) to a path's wavelengths.
  Spectrum ratio(const Spectrum& value, const Spectrum& base) const;
  // An emitter of linear Rec. 709 radiance `rgb` at the three wavelengths: the uplift times
  // D65 / integral(D65 ybar), so that the RGB mode's white emitter (1, 1, 1) is D65 of
  // luminance Y = 1 and comes out white (as colour.h's reflectances do).
  Spectrum illuminant(const Spectrum& rgb) const;
  // The linear Rec. 709 colour estimated from a radiance at the three wavelengths: the XYZ of
  // the CIE 1931 observer, X = (1/3) sum_i L_i xbar(lambda_i) / p(lambda_i) (likewise Y, Z),
  // then the sRGB matrix. Its expectation is the colour of the radiance spectrum.
  Spectrum radiance_to_rgb(const Spectrum& radiance) const;
  // The colour of a reflectance at the three wavelengths lit by D65 (for the albedo AOV).
  Spectrum reflectance_to_rgb(const Spectrum& reflectance) const;

 private:
  double nm_[kChannels] = {};
  double pdf_[kChannels] = {};
  double basis_[kChannels][3] = {};  // B_r, B_g, B_b at each wavelength
  double d65_[kChannels] = {};       // D65(lambda) / integral(D65 ybar)
  double xyz_[kChannels][3] = {};    // (xbar, ybar, zbar)(lambda) / (3 p(lambda))
};

}  // namespace lamina
