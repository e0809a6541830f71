#include "materials/spectral/chromophores.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "materials/spectral/prospect.h"
#include "materials/spectral/tables.h"
#include "materials/spectral/tabulated_spectrum.h"

namespace lamina {
namespace {

using namespace spectral_tables;

constexpr double kPerCmToPerMm = 0.1;
// Prahl's conversion of a molar extinction to whole blood: mu_a = ln(10) eps C with
// C = 150 g/L / 64500 g/mol (Prahl, "Optical absorption of hemoglobin", OMLC 1999).
constexpr double kHaemoglobinGramsPerLitre = 150.0;
constexpr double kHaemoglobinMolarMass = 64500.0;

const TabulatedSpectrum& haemoglobin(bool oxy) {
  static const std::array<TabulatedSpectrum, 2> table = [] {
    std::vector<double> nm, o, d;
    for (int i = 0; i < kHaemoglobinRows; ++i) {
      nm.push_back(kHaemoglobin[i].nm);
      o.push_back(kHaemoglobin[i].oxy);
      d.push_back(kHaemoglobin[i].deoxy);
    }
    return std::array<TabulatedSpectrum, 2>{TabulatedSpectrum(nm, d), TabulatedSpectrum(nm, o)};
  }();
  return table[oxy ? 1 : 0];
}

const TabulatedSpectrum& fat() {
  static const TabulatedSpectrum table = [] {
    std::vector<double> nm, v;
    for (int i = 0; i < kFatRows; ++i) {
      nm.push_back(kFat[i].nm);
      v.push_back(kFat[i].value);
    }
    return TabulatedSpectrum(nm, v);
  }();
  return table;
}

double blood(bool oxy, double nm) {
  return std::log(10.0) * haemoglobin(oxy)(nm) * kHaemoglobinGramsPerLitre / kHaemoglobinMolarMass * kPerCmToPerMm;
}

}  // namespace

double eumelanin_absorption(double nm) { return 6.6e10 * std::pow(nm, -3.33); }
double pheomelanin_absorption(double nm) { return 2.9e14 * std::pow(nm, -4.75); }
double oxy_blood_absorption(double nm) { return blood(true, nm); }
double deoxy_blood_absorption(double nm) { return blood(false, nm); }

// PROSPECT-D's water and carotenoid columns through its own model's absorption: a leaf of only
// 1 cm of water (or 1 ug/cm2 of carotenoids) absorbs K = Kw (or Kcar).
double water_absorption(double nm) {
  ProspectParameters p;
  p.chlorophyll = p.carotenoids = p.dry_matter = 0.0;
  p.water = 1.0;
  return prospect_d_absorption(p, nm) * kPerCmToPerMm;
}

double carotene_absorption_per_concentration(double nm) {
  ProspectParameters p;
  p.chlorophyll = p.water = p.dry_matter = 0.0;
  p.carotenoids = 1.0;
  return prospect_d_absorption(p, nm) * kPerCmToPerMm;
}

double fat_absorption(double nm) { return fat()(nm) * kPerCmToPerMm; }

double skin_baseline_absorption(double nm) { return (0.244 + 85.3 * std::exp(-(nm - 154.0) / 66.2)) * kPerCmToPerMm; }

double ScatteringPowerLaw::reduced(double nm) const {
  const double x = nm / 500.0;
  return reduced_500 * (f_rayleigh * std::pow(x, -4.0) + (1.0 - f_rayleigh) * std::pow(x, -b_mie));
}

double SkinChromophores::absorption(double nm) const {
  return melanin * (eumelanin * eumelanin_absorption(nm) + (1.0 - eumelanin) * pheomelanin_absorption(nm)) +
         blood * (oxygenation * oxy_blood_absorption(nm) + (1.0 - oxygenation) * deoxy_blood_absorption(nm)) +
         water * water_absorption(nm) + fat * fat_absorption(nm) + carotene * carotene_absorption_per_concentration(nm) +
         baseline * skin_baseline_absorption(nm);
}

const std::array<ChromophoreKey, 8>& chromophore_keys() {
  static const std::array<ChromophoreKey, 8> keys = {{
      {"melanin", &SkinChromophores::melanin, 1.0, true},
      {"eumelanin", &SkinChromophores::eumelanin, 1.0, false},
      {"blood", &SkinChromophores::blood, 1.0, true},
      {"oxygenation", &SkinChromophores::oxygenation, 1.0, false},
      {"water", &SkinChromophores::water, 1.0, true},
      {"fat", &SkinChromophores::fat, 1.0, true},
      {"carotene", &SkinChromophores::carotene, std::numeric_limits<double>::infinity(), false},
      {"baseline", &SkinChromophores::baseline, 1.0, true},
  }};
  return keys;
}

const ChannelWeights& rec709_channel_weights() {
  static const ChannelWeights weights = [] {
    static_assert(sizeof(ChannelWeights::w) / sizeof(ChannelWeights::w[0]) == 85, "the colour grid");
    ChannelWeights cw{};
    std::array<double, 3> sum{0.0, 0.0, 0.0};
    for (int i = 0; i < kCie1931Rows && i < 85; ++i) {
      const CieRow& row = kCie1931[i];
      for (int c = 0; c < 3; ++c) {
        const double r = kXyzToRec709[c][0] * row.x + kXyzToRec709[c][1] * row.y + kXyzToRec709[c][2] * row.z;
        cw.w[i][c] = row.d65 * r;
        sum[c] += cw.w[i][c];
      }
    }
    for (auto& w : cw.w)
      for (int c = 0; c < 3; ++c) w[c] /= sum[c];
    return cw;
  }();
  return weights;
}

namespace {

// The chromophores' absorption on the colour grid, tabulated once.
struct GridChromophores {
  std::array<double, 85> eumelanin, pheomelanin, oxy, deoxy, water, fat, carotene, baseline;
  std::array<double, 85> log_x, rayleigh;  // ln(nm / 500) and (nm / 500)^-4, for the power law
};

const GridChromophores& on_grid() {
  static const GridChromophores g = [] {
    GridChromophores q;
    const ChannelWeights& cw = rec709_channel_weights();
    for (int i = 0; i < 85; ++i) {
      const double nm = cw.nm(i);
      q.eumelanin[i] = eumelanin_absorption(nm);
      q.pheomelanin[i] = pheomelanin_absorption(nm);
      q.oxy[i] = oxy_blood_absorption(nm);
      q.deoxy[i] = deoxy_blood_absorption(nm);
      q.water[i] = water_absorption(nm);
      q.fat[i] = fat_absorption(nm);
      q.carotene[i] = carotene_absorption_per_concentration(nm);
      q.baseline[i] = skin_baseline_absorption(nm);
      q.log_x[i] = std::log(nm / 500.0);
      q.rayleigh[i] = std::pow(nm / 500.0, -4.0);
    }
    return q;
  }();
  return g;
}

// Total diffuse reflectance of a semi-infinite medium as a function of x = sqrt(3 (1 - a')), a'
// its reduced albedo: R_d = (a'/2) (1 + exp(-4/3 A x)) exp(-x) (Jensen, Marschner, Levoy and
// Hanrahan 2001, eq. 5 with its dipole's boundary term A at the tissue's index 1.4: A = (1 +
// F_dr) / (1 - F_dr), F_dr = -1.440/n^2 + 0.710/n + 0.668 + 0.0636 n). Decreasing in x on [0, sqrt 3].
struct DiffuseReflectance {
  double k;  // 4/3 A
  DiffuseReflectance() {
    constexpr double n = 1.4;
    const double f_dr = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
    k = 4.0 / 3.0 * (1.0 + f_dr) / (1.0 - f_dr);
  }
  double operator()(double x) const { return 0.5 * (1.0 - x * x / 3.0) * (1.0 + std::exp(-k * x)) * std::exp(-x); }
  // The absorption whose R_d at reduced scattering s is r: Newton's method on x, kept inside the
  // bracket that the signs of R_d - r narrow (bisection where a step would leave it); the same
  // steps for the same numbers, so deterministic.
  double absorption(double r, double s) const {
    double lo = 0.0, hi = std::sqrt(3.0), x = 0.5 * hi;
    for (int it = 0; it < 40; ++it) {
      const double e = std::exp(-x), ek = std::exp(-k * x), q = 1.0 - x * x / 3.0;
      const double f = 0.5 * q * (1.0 + ek) * e - r;
      (f > 0.0 ? lo : hi) = x;
      const double slope = 0.5 * e * (-2.0 * x / 3.0 * (1.0 + ek) - k * q * ek - q * (1.0 + ek));
      double next = x - f / slope;
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      const bool done = std::abs(next - x) <= 1e-15 * next;
      x = next;
      if (done) break;
    }
    const double albedo = 1.0 - x * x / 3.0;
    return albedo > 0.0 ? s * (1.0 - albedo) / albedo : std::numeric_limits<double>::infinity();
  }
};

}  // namespace

// Per channel, the absorption that gives the channel's mean diffuse reflectance, sum_nm w_c R_d(nm),
// at the channel's mean reduced scattering: the channel sees the spectrum as a diffuse reflector
// does, not as the mean coefficient (which blood's narrow bands near 560 nm would dominate in red).
// A layer that does not scatter takes the mean coefficient.
Spectrum SkinChromophores::absorption_rgb() const {
  const GridChromophores& q = on_grid();
  const ChannelWeights& cw = rec709_channel_weights();
  static const DiffuseReflectance rd;
  Spectrum mean_a(0.0), mean_r(0.0), mean_s(0.0);
  for (int i = 0; i < 85; ++i) {
    const double a = melanin * (eumelanin * q.eumelanin[i] + (1.0 - eumelanin) * q.pheomelanin[i]) +
                     blood * (oxygenation * q.oxy[i] + (1.0 - oxygenation) * q.deoxy[i]) + water * q.water[i] +
                     fat * q.fat[i] + carotene * q.carotene[i] + baseline * q.baseline[i];
    // scattering.reduced(nm), with the powers from the table.
    const double s = scattering.reduced_500 * (scattering.f_rayleigh * q.rayleigh[i] +
                                               (1.0 - scattering.f_rayleigh) * std::exp(-scattering.b_mie * q.log_x[i]));
    const double r = s > 0.0 ? rd(std::sqrt(3.0 * a / (a + s))) : 0.0;
    for (int c = 0; c < kChannels; ++c) {
      mean_a[c] += cw.w[i][c] * a;
      mean_r[c] += cw.w[i][c] * r;
      mean_s[c] += cw.w[i][c] * s;
    }
  }
  if (!(scattering.reduced_500 > 0.0)) return {std::max(0.0, mean_a[0]), std::max(0.0, mean_a[1]), std::max(0.0, mean_a[2])};
  Spectrum out;
  for (int c = 0; c < kChannels; ++c) out[c] = rd.absorption(mean_r[c], mean_s[c]);
  return out;
}

Spectrum SkinChromophores::scattering_coefficient_rgb() const {
  return rec709_channel_mean([this](double nm) { return scattering_coefficient(nm); });
}

}  // namespace lamina
