#include "materials/spectral/chromophores.h"

#include <array>
#include <cmath>
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

}  // namespace lamina
