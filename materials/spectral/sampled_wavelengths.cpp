#include "materials/spectral/sampled_wavelengths.h"

#include <algorithm>
#include <cmath>

#include "materials/base/sampling.h"
#include "materials/spectral/colour.h"
#include "materials/spectral/tables.h"
#include "materials/spectral/uplift.h"

namespace lamina {
namespace {

using spectral_tables::CieRow;
using spectral_tables::kCie1931;
using spectral_tables::kCie1931Rows;

// pbrt-v4's visible density: p = k / ((b - a) cosh^2(k (lambda - 538))) with a, b = tanh(k (end
// - 538)) at the two ends, whose CDF is (tanh(k (lambda - 538)) - a) / (b - a).
constexpr double kCentreNm = 538.0, kSharpness = 0.0072;
double tanh_at(double nm) { return std::tanh(kSharpness * (nm - kCentreNm)); }

// The CIE row at nm: linear interpolation on the uniform 5-nm table (360-780 nm), held beyond
// its ends like TabulatedSpectrum.
CieRow cie_at(double nm) {
  const double first = kCie1931[0].nm, step = kCie1931[1].nm - first;
  const double x = std::clamp((nm - first) / step, 0.0, static_cast<double>(kCie1931Rows - 1));
  const int i = std::min(static_cast<int>(x), kCie1931Rows - 2);
  const double t = x - i;
  const CieRow& a = kCie1931[i];
  const CieRow& b = kCie1931[i + 1];
  return {nm, a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z), a.d65 + t * (b.d65 - a.d65)};
}

// integral of D65 ybar over [360, 830] nm, both read as cie_at reads them: on each 5-nm interval
// the product of two linear functions is a quadratic, which Simpson's rule integrates exactly;
// beyond 780 nm both are held, a constant. This is the estimator's own normalisation, so a white
// reflector under the white emitter has Y = 1 in expectation exactly.
double d65_luminance() {
  double sum = 0.0;
  for (int i = 0; i + 1 < kCie1931Rows; ++i) {
    const double a = kCie1931[i].nm, b = kCie1931[i + 1].nm, m = 0.5 * (a + b);
    auto f = [](double nm) {
      const CieRow r = cie_at(nm);
      return r.d65 * r.y;
    };
    sum += (b - a) / 6.0 * (f(a) + 4.0 * f(m) + f(b));
  }
  const CieRow& last = kCie1931[kCie1931Rows - 1];
  return sum + (kSpectralLastNm - last.nm) * last.d65 * last.y;
}

}  // namespace

double visible_wavelength_pdf(double nm) {
  if (nm < kSpectralFirstNm || nm > kSpectralLastNm) return 0.0;
  const double a = tanh_at(kSpectralFirstNm), b = tanh_at(kSpectralLastNm);
  const double c = std::cosh(kSharpness * (nm - kCentreNm));
  return kSharpness / ((b - a) * c * c);
}

double sample_visible_wavelength(double u) {
  const double a = tanh_at(kSpectralFirstNm), b = tanh_at(kSpectralLastNm);
  const double nm = kCentreNm + std::atanh(a + u * (b - a)) / kSharpness;
  return std::clamp(nm, kSpectralFirstNm, kSpectralLastNm);
}

SampledWavelengths SampledWavelengths::from_uniform(double u) {
  double nm[kChannels];
  for (int i = 0; i < kChannels; ++i) {
    double ui = u + static_cast<double>(i) / kChannels;
    if (ui >= 1.0) ui -= 1.0;
    nm[i] = sample_visible_wavelength(ui);
  }
  return at(nm[0], nm[1], nm[2]);
}

SampledWavelengths SampledWavelengths::at(double nm0, double nm1, double nm2) {
  static const double inv_luminance = 1.0 / d65_luminance();
  SampledWavelengths w;
  const double nm[kChannels] = {nm0, nm1, nm2};
  for (int i = 0; i < kChannels; ++i) {
    w.nm_[i] = nm[i];
    w.pdf_[i] = visible_wavelength_pdf(w.nm_[i]);
    const std::array<double, 3> b = rgb_basis(w.nm_[i]);
    std::copy(b.begin(), b.end(), w.basis_[i]);
    const CieRow r = cie_at(w.nm_[i]);
    w.d65_[i] = r.d65 * inv_luminance;
    const double weight = 1.0 / (kChannels * w.pdf_[i]);
    w.xyz_[i][0] = r.x * weight;
    w.xyz_[i][1] = r.y * weight;
    w.xyz_[i][2] = r.z * weight;
  }
  return w;
}

// Stratified over a pixel's samples. Each sample's u must be uniform on [0, 1) and independent
// of the sample's own random stream (then each sample's estimate is unbiased, for any number of
// samples); nothing requires the samples of a pixel to be independent of each other. With o
// uniform from the stream (seed, pixel, kWavelengthStream) and u_s = frac(o + s phi), every u_s
// is uniform (a uniform rotation of the circle), and the u_s of samples 0..n-1 are the Kronecker
// (golden ratio) sequence, whose points are spread evenly over [0, 1) for every n (its gaps take
// at most three lengths: the three-distance theorem), so a pixel's wavelengths cover the
// spectrum evenly instead of clumping as independent draws do. The stream never depends on the
// thread that renders the sample.
SampledWavelengths SampledWavelengths::for_sample(std::uint64_t seed, std::uint64_t pixel, std::uint64_t sample) {
  constexpr std::uint64_t kWavelengthStream = 1ull << 61;  // far above any sample index, apart from the hero strata's
  // In 64-bit fixed point, where the sum wraps modulo 1 exactly: 2^64 phi, rounded to odd.
  constexpr std::uint64_t kPhi64 = 0x9e3779b97f4a7c15ull;
  Rng rng(seed, pixel, kWavelengthStream);
  const std::uint64_t u = rng.next_u64() + sample * kPhi64;
  return from_uniform(static_cast<double>(u >> 11) * 0x1.0p-53);  // 53 bits: in [0, 1)
}

Spectrum SampledWavelengths::reflectance(const Spectrum& rgb) const {
  Spectrum s;
  for (int i = 0; i < kChannels; ++i) s[i] = basis_[i][0] * rgb[0] + basis_[i][1] * rgb[1] + basis_[i][2] * rgb[2];
  return s;
}

Spectrum SampledWavelengths::ratio(const Spectrum& value, const Spectrum& base) const {
  Spectrum r(1.0);
  for (int c = 0; c < kChannels; ++c)
    if (base[c] > 0.0) r[c] = value[c] / base[c];
  return r.is_grey() ? r : reflectance(r);
}

Spectrum SampledWavelengths::illuminant(const Spectrum& rgb) const {
  Spectrum s = reflectance(rgb);
  for (int i = 0; i < kChannels; ++i) s[i] *= d65_[i];
  return s;
}

Spectrum SampledWavelengths::radiance_to_rgb(const Spectrum& radiance) const {
  Xyz xyz;
  for (int i = 0; i < kChannels; ++i) {
    xyz.x += radiance[i] * xyz_[i][0];
    xyz.y += radiance[i] * xyz_[i][1];
    xyz.z += radiance[i] * xyz_[i][2];
  }
  return xyz_to_linear_rec709(xyz);
}

Spectrum SampledWavelengths::reflectance_to_rgb(const Spectrum& reflectance) const {
  Spectrum lit = reflectance;
  for (int i = 0; i < kChannels; ++i) lit[i] *= d65_[i];
  return radiance_to_rgb(lit);
}

}  // namespace lamina
