#include "materials/spectral/leaf_chromophores.h"

#include <cmath>
#include <limits>

namespace lamina {

// Kubelka and Munk (1931): a non-absorbing layer of scattering power S and thickness d transmits
// 1 / (1 + S d) of diffuse light; Stokes' pile of m non-absorbing plates of diffuse transmittance
// t transmits 1 / (1 + m (1 - t) / t) (materials/spectral/prospect.cpp, stokes_pile). So one
// plate is S d = (1 - t) / t, and with the diffusion theory's S = (3/4) mu_s' (van Gemert and Star
// 1987, Lasers Life Sci. 1:287) its reduced scattering optical thickness is (4/3) (1 - t) / t.
double plate_reduced_scattering_depth(double nm) {
  const double t = plate(90.0, prospect_refractive_index(nm), 1.0, false).transmittance;
  return 4.0 / 3.0 * (1.0 - t) / t;
}

double LeafChromophores::absorption(double nm, double thickness_mm) const {
  return prospect_d_absorption(contents, nm) / thickness_mm;
}

double LeafChromophores::scattering_coefficient(double nm, double thickness_mm) const {
  return plates * plate_reduced_scattering_depth(nm) * std::pow(nm / 1000.0, -scattering_power) / (thickness_mm * (1.0 - g));
}

const std::array<LeafKey, std::size(kLeafContentKeys) + 3>& leaf_keys() {
  static const auto keys = [] {
    const double inf = std::numeric_limits<double>::infinity();
    std::array<LeafKey, std::size(kLeafContentKeys) + 3> k{};
    std::size_t i = 0;
    for (const LeafContentKey& c : kLeafContentKeys) k[i++] = {c.key, 0.0, inf, c.member, nullptr};
    k[i++] = {"plates", 0.0, inf, nullptr, &LeafChromophores::plates};
    k[i++] = {"scattering_power", -4.0, 4.0, nullptr, &LeafChromophores::scattering_power};
    k[i++] = {"g", -1.0, 1.0, nullptr, &LeafChromophores::g};
    return k;
  }();
  return keys;
}

const std::vector<const char*>& leaf_key_names() {
  static const std::vector<const char*> names = [] {
    std::vector<const char*> n;
    for (const LeafKey& k : leaf_keys()) n.push_back(k.name);
    return n;
  }();
  return names;
}

}  // namespace lamina
