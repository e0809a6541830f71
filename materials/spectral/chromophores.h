// Skin from its chromophores: the absorption and scattering coefficients of a tissue layer from
// volume fractions of melanosomes, blood, water and fat, its blood's oxygen saturation and its
// carotene, after Jacques (2013, "Optical properties of biological tissues: a review", Phys. Med. Biol.
// 58:R37) and Donner and Jensen (2006, "A spectral BSSRDF for shading human skin", EGSR). Coefficients in 1/mm, Lamina's unit (docs/contracts.md,
// "Units"); wavelengths in nm. Tables, sources and where each is held beyond its range:
// docs/spectral.md, "Skin chromophores".
#pragma once

#include <array>

#include "materials/base/spectrum.h"

namespace lamina {

// Absorption of the pure chromophores, 1/mm.
// Eumelanin and pheomelanin inside melanosomes, power laws of Donner and Jensen (2006):
// 6.6e10 nm^-3.33 and 2.9e14 nm^-4.75 (1/mm; 68 and 44 1/mm at 500 nm, close to
// Jacques' 519 (nm/500)^-3.5 1/cm for melanosomes).
double eumelanin_absorption(double nm);
double pheomelanin_absorption(double nm);
// Whole blood (haemoglobin 150 g/L, molar mass 64500 g/mol) fully oxygenated or deoxygenated:
// ln(10) eps(nm) 150 / 64500 from Prahl's molar extinction eps (held beyond 250-1000 nm).
double oxy_blood_absorption(double nm);
double deoxy_blood_absorption(double nm);
// Pure water: PROSPECT-D's water coefficient (Feret et al. 2017; 400-2500 nm).
double water_absorption(double nm);
// Fat (SIMPA's table, 450-1000 nm, held beyond).
double fat_absorption(double nm);
// Carotenoids per concentration, 1/mm per (ug/cm3): PROSPECT-D's in-vivo carotenoid specific
// absorption (cm2/ug) standing in for beta-carotene (docs/spectral.md says why).
double carotene_absorption_per_concentration(double nm);
// Bloodless tissue (Jacques 1998, Saidi 1992): 0.244 + 85.3 exp(-(nm - 154) / 66.2) 1/cm.
double skin_baseline_absorption(double nm);

// Reduced scattering of a Mie-plus-Rayleigh power law (Jacques 2013):
//   mu_s'(nm) = mu_s'(500) [f_Ray (nm/500)^-4 + (1 - f_Ray) (nm/500)^-b_Mie].
struct ScatteringPowerLaw {
  double reduced_500 = 0.0;  // mu_s' at 500 nm, 1/mm
  double f_rayleigh = 0.0;   // Rayleigh's share at 500 nm, [0, 1]
  double b_mie = 1.0;        // Mie power
  double reduced(double nm) const;
};

// A tissue layer by its chromophores. Its absorption (the sum of Jacques 2013; Donner and Jensen
// 2006 write the same with the baseline filling what melanin or blood leave) is
//   mu_a = M [b mu_eu + (1 - b) mu_pheo] + B [S mu_oxy + (1 - S) mu_deoxy] + W mu_water
//          + F mu_fat + C mu_carotene + baseline mu_baseline,
// its scattering sigma_s = mu_s' / (1 - g), phase function Henyey-Greenstein with g.
struct SkinChromophores {
  double melanin = 0.0;      // M: volume fraction of melanosomes, [0, 1]
  double eumelanin = 1.0;    // b: eumelanin share of the melanin, [0, 1]
  double blood = 0.0;        // B: volume fraction of whole blood, [0, 1]
  double oxygenation = 0.75; // S: oxygen saturation of the blood, [0, 1]
  double water = 0.0;        // W: volume fraction, [0, 1]
  double fat = 0.0;          // F: volume fraction, [0, 1]
  double carotene = 0.0;     // C: ug/cm3 (= mg/L), >= 0
  double baseline = 0.0;     // volume fraction of bloodless tissue absorbing as skin_baseline_absorption
  ScatteringPowerLaw scattering;
  double g = 0.8;            // Henyey-Greenstein asymmetry, |g| < 1

  double absorption(double nm) const;  // 1/mm
  double scattering_coefficient(double nm) const { return scattering.reduced(nm) / (1.0 - g); }  // 1/mm

  // The RGB mode's coefficients (1/mm). Scattering: each channel's mean of the spectrum
  // (rec709_channel_mean). Absorption: per channel, the coefficient whose diffuse reflectance (a
  // semi-infinite layer at the channel's mean scattering, the dipole's R_d) equals the channel's
  // colour of the layer's diffuse reflectance spectrum, so that the RGB mode shows about the colour
  // the spectrum gives (docs/skin_tones.md measures how close); the mean of the coefficient would
  // let blood's narrow bands near 560 nm darken the red channel. A layer that does not scatter
  // takes the mean coefficient. A function of the chromophores alone: a map that drives one
  // recomputes it per shading point (docs/stack_bindings.md, "Chromophore parameters").
  Spectrum absorption_rgb() const;
  Spectrum scattering_coefficient_rgb() const;
};

// The scalar keys of a "chromophores" object, declared once for the material-file reader and the
// stack parameters that bind them (docs/spectral.md, "Skin chromophores"). A volume fraction
// counts towards the sum M + B + W + F + baseline <= 1.
struct ChromophoreKey {
  const char* name;
  double SkinChromophores::*member;
  double max;          // the range is [0, max]; max may be +infinity
  bool volume_fraction;
};
const std::array<ChromophoreKey, 8>& chromophore_keys();

// The weights that project a spectrum onto a linear Rec. 709 channel (c = 0, 1, 2), on the
// colour grid (360-780 nm every 5 nm, materials/spectral/colour.h): w_c(nm) proportional to
// D65(nm) r_c(nm), r_c = sum_k M[c][k] xyz_bar_k the channel's colour-matching function (M the
// sRGB matrix; negative where the channel's primary is out of gamut), normalised to sum 1 so that a
// grey spectrum projects to the same grey. Of a reflectance spectrum, sum w_c R is its colour under
// D65 (reflectance_to_linear_rec709 up to the white point's 1e-4).
struct ChannelWeights {
  std::array<double, 3> w[85];  // [wavelength index][channel]
  double nm(int i) const { return 360.0 + 5.0 * i; }
};
const ChannelWeights& rec709_channel_weights();
template <typename F>
Spectrum rec709_channel_mean(F f) {
  const ChannelWeights& cw = rec709_channel_weights();
  Spectrum out(0.0);
  for (int i = 0; i < 85; ++i) {
    const double v = f(cw.nm(i));
    for (int c = 0; c < kChannels; ++c) out[c] += cw.w[i][c] * v;
  }
  return out;
}

}  // namespace lamina
