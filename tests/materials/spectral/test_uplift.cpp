// The spectral renderer's colour machinery (materials/spectral/uplift.h, sampled_wavelengths.h):
// the RGB uplift's published properties and round trip, the visible-wavelength density, and the
// estimator that turns a path's three wavelengths into a colour, against integrals computed
// independently here.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "materials/base/sampling.h"
#include "materials/spectral/colour.h"
#include "materials/spectral/sampled_wavelengths.h"
#include "materials/spectral/uplift.h"
#include "tests/materials/spectral/colour_quadrature.h"

namespace lamina {
namespace {

// Mallett and Yuksel's basis is non-negative and sums to 1 at every wavelength (their
// constraints; the published values are rounded: colour-science's copy sums to 1 within 1e-5,
// the largest deviation at 780 nm).
TEST(Uplift, BasisIsAPartitionOfUnity) {
  for (double nm = 340.0; nm <= 850.0; nm += 0.5) {
    const std::array<double, 3> b = rgb_basis(nm);
    EXPECT_GE(b[0], 0.0);
    EXPECT_GE(b[1], 0.0);
    EXPECT_GE(b[2], 0.0);
    EXPECT_NEAR(b[0] + b[1] + b[2], 1.0, 1e-5) << nm;
  }
  // So a grey is flat and every reflectance in [0, 1]^3 stays in [0, 1].
  EXPECT_NEAR(uplift(Spectrum(0.37), 612.3), 0.37, 0.37e-5);
  EXPECT_LE(uplift(Spectrum(1.0, 0.0, 1.0), 540.0), 1.0);
}

// The round trip: the colour under D65 (colour.h, the 5-nm CIE tables) of the uplift of a linear
// Rec. 709 colour is that colour. The basis was optimised for an exact round trip; what remains
// is the 5-nm D65 table's white point against the colour space's rounded one (a perfect
// reflector comes out within 8.5e-5 of white: test_spectral_colour), so we allow 2e-4, about
// twice that, over a grid of colours in [0, 1]^3 and random ones.
TEST(Uplift, RoundTripsLinearRec709) {
  std::vector<Spectrum> colours;
  for (double r : {0.0, 0.5, 1.0})
    for (double g : {0.0, 0.5, 1.0})
      for (double b : {0.0, 0.5, 1.0}) colours.emplace_back(r, g, b);
  Rng rng(3, 0);
  for (int i = 0; i < 50; ++i) colours.emplace_back(rng.uniform(), rng.uniform(), rng.uniform());
  for (const Spectrum& rgb : colours) {
    const Spectrum back = reflectance_to_linear_rec709(uplifted(rgb));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back[c], rgb[c], 2e-4) << rgb[0] << "," << rgb[1] << "," << rgb[2] << " channel " << c;
  }
}

// pbrt-v4's visible density integrates to 1 over 360-830 nm and sample_visible_wavelength is its
// inverse CDF: the CDF, integrated here by the midpoint rule, at the sampled wavelength is u.
TEST(SampledWavelengths, VisibleDensityAndItsInverse) {
  const int n = 47000;  // 0.01-nm steps
  const double h = (kSpectralLastNm - kSpectralFirstNm) / n;
  double cdf = 0.0;
  std::vector<double> cdf_at(n + 1, 0.0);
  for (int i = 0; i < n; ++i) {
    cdf += h * visible_wavelength_pdf(kSpectralFirstNm + (i + 0.5) * h);
    cdf_at[i + 1] = cdf;
  }
  EXPECT_NEAR(cdf, 1.0, 1e-8);
  EXPECT_EQ(visible_wavelength_pdf(359.0), 0.0);
  EXPECT_EQ(visible_wavelength_pdf(831.0), 0.0);
  for (double u : {0.001, 0.1, 0.25, 0.5, 0.77, 0.999}) {
    const double nm = sample_visible_wavelength(u);
    const double x = (nm - kSpectralFirstNm) / h;
    const int i = static_cast<int>(x);
    const double at = cdf_at[i] + (x - i) * (cdf_at[i + 1] - cdf_at[i]);
    EXPECT_NEAR(at, u, 1e-7) << u;
  }
}

// The companions sit a third of the sampling domain away from the hero, in u.
TEST(SampledWavelengths, CompanionsAreRotatedByAThird) {
  const double u = 0.9;
  const SampledWavelengths w = SampledWavelengths::from_uniform(u);
  EXPECT_DOUBLE_EQ(w.nm(0), sample_visible_wavelength(0.9));
  EXPECT_NEAR(w.nm(1), sample_visible_wavelength(0.9 + 1.0 / 3.0 - 1.0), 1e-9);
  EXPECT_NEAR(w.nm(2), sample_visible_wavelength(0.9 + 2.0 / 3.0 - 1.0), 1e-9);
  for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(w.pdf(i), visible_wavelength_pdf(w.nm(i)));
}

// The colour of the white emitter's uplifted light reflected by an uplifted reflectance rho, by
// an independent route (colour_quadrature.h).
Spectrum colour_by_quadrature(const Spectrum& rho) {
  return test::colour_by_quadrature([&](double nm) { return uplift(rho, nm); });
}

// The estimator's expectation over the hero's u (by the midpoint rule on 10^5 points, smooth in
// u between the table's nodes) is the colour of the spectrum: for the light of the white emitter
// reflected by rho, radiance_to_rgb(illuminant(1) * reflectance(rho)) and reflectance_to_rgb
// both. The quadrature in u resolves the 5-nm tables' kinks to about 1e-6.
TEST(SampledWavelengths, EstimatesTheColourOfASpectrum) {
  for (const Spectrum& rho : {Spectrum(1.0), Spectrum(0.8, 0.2, 0.1), Spectrum(0.1, 0.6, 0.9)}) {
    const int n = 100000;
    Spectrum mean_radiance(0.0), mean_reflectance(0.0);
    for (int i = 0; i < n; ++i) {
      const SampledWavelengths w = SampledWavelengths::from_uniform((i + 0.5) / n);
      mean_radiance += w.radiance_to_rgb(w.illuminant(Spectrum(1.0)) * w.reflectance(rho)) / n;
      mean_reflectance += w.reflectance_to_rgb(w.reflectance(rho)) / n;
    }
    const Spectrum expected = colour_by_quadrature(rho);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(mean_radiance[c], expected[c], 1e-5) << c;
      EXPECT_NEAR(mean_reflectance[c], expected[c], 1e-5) << c;
      // and the colour is rho's up to the quadrature rule: the renderer integrates the linearly
      // interpolated tables over the continuum, the round trip (within 2e-4) was made for the
      // sums every 5 nm; the two rules differ by up to 1.0e-3 on these colours (docs/spectral.md).
      EXPECT_NEAR(mean_radiance[c], rho[c], 1.5e-3) << c;
    }
  }
}

// A pixel's wavelengths: the same for the same (seed, pixel, sample), another pixel's differ,
// and over a pixel's first n samples the heroes' u (the CDF at the hero) are the golden-ratio
// sequence rotated: every tenth of [0, 1) holds n/10 of them within 2 (for n = 1000; independent
// draws would scatter by sqrt(90) = 9.5).
TEST(SampledWavelengths, StratifiedOverAPixelsSamples) {
  const SampledWavelengths a = SampledWavelengths::for_sample(5, 123, 7), b = SampledWavelengths::for_sample(5, 123, 7);
  EXPECT_EQ(a.nm(0), b.nm(0));
  EXPECT_NE(a.nm(0), SampledWavelengths::for_sample(5, 124, 7).nm(0));
  EXPECT_NE(a.nm(0), SampledWavelengths::for_sample(6, 123, 7).nm(0));
  const double ta = std::tanh(0.0072 * (kSpectralFirstNm - 538.0)), tb = std::tanh(0.0072 * (kSpectralLastNm - 538.0));
  for (std::uint64_t pixel : {0ull, 99ull, 4567ull}) {
    int bins[10] = {};
    const int n = 1000;
    for (int s = 0; s < n; ++s) {
      const double u = (std::tanh(0.0072 * (SampledWavelengths::for_sample(1, pixel, s).nm(0) - 538.0)) - ta) / (tb - ta);
      ++bins[std::min(9, static_cast<int>(u * 10.0))];
    }
    for (int k = 0; k < 10; ++k) EXPECT_NEAR(bins[k], n / 10, 2) << "pixel " << pixel << " bin " << k;
  }
}

}  // namespace
}  // namespace lamina
