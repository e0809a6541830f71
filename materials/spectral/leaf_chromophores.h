// A layer of a leaf (cuticle, palisade or spongy mesophyll) from what it holds: its absorption
// from PROSPECT-D's specific absorption coefficients (materials/spectral/prospect.h), its
// scattering from the air-cell-wall interfaces it holds, counted in PROSPECT plates, and its
// refractive index PROSPECT-D's. Derivations and sources: docs/spectral.md, "Layered leaf".
#pragma once

#include <array>
#include <iterator>
#include <vector>

#include "materials/spectral/prospect.h"

namespace lamina {

// The keys of a leaf layer's contents, with their units, declared once: the material file's
// "leaf" object, the fit's parameter paths, the texture bindings (leaf_keys below) and the docs'
// table follow this list.
struct LeafContentKey {
  const char* key;
  double LeafContents::*member;
  const char* unit;
};
inline constexpr LeafContentKey kLeafContentKeys[] = {
    {"chlorophyll", &LeafContents::chlorophyll, "ug/cm2"}, {"carotenoids", &LeafContents::carotenoids, "ug/cm2"},
    {"anthocyanins", &LeafContents::anthocyanins, "ug/cm2"}, {"brown", &LeafContents::brown, "arbitrary units"},
    {"water", &LeafContents::water, "cm"},                   {"dry_matter", &LeafContents::dry_matter, "g/cm2"}};

// The reduced scattering optical thickness of one PROSPECT plate of leaf material (index n at nm)
// seen as a Kubelka-Munk layer: (4/3) (1 - t) / t, t the plate's transmittance for diffuse light
// without absorption (docs/spectral.md, "Layered leaf").
double plate_reduced_scattering_depth(double nm);

// One layer of thickness d (mm, finite and > 0): its contents per leaf area, as many plates'
// worth of scattering, and a Henyey-Greenstein asymmetry. Coefficients in 1/mm.
struct LeafChromophores {
  LeafContents contents;
  double plates = 0.0;            // >= 0
  double scattering_power = 0.0;  // b: the plates' scattering times (nm / 1000)^-b, |b| <= 4
  double g = 0.0;                 // |g| < 1

  // sigma_a = K(nm) / d: PROSPECT-D's K is the normal optical thickness of the contents.
  double absorption(double nm, double thickness_mm) const;
  // sigma_s = plates (4/3)(1 - t)/t (nm / 1000)^-b / (d (1 - g)).
  double scattering_coefficient(double nm, double thickness_mm) const;
  // PROSPECT-D's refractive index of leaf material, the layer's at every wavelength.
  static double refractive_index(double nm) { return prospect_refractive_index(nm); }
};

// Every key of a material file's "leaf" object with its range, declared once (the contents from
// kLeafContentKeys, then plates, scattering_power and g): the file reader
// (materials/stack/stack_file.cpp) accepts these keys, and a texture may drive any of them
// (layers[i].leaf.KEY, materials/stack/stack_parameters.h).
struct LeafKey {
  const char* name;
  double lo, hi;                   // the range; g's is open (|g| < 1), the others closed
  double LeafContents::*content;   // a content per leaf area, or null
  double LeafChromophores::*own;   // plates, scattering_power or g, or null
  double& of(LeafChromophores& c) const { return content ? c.contents.*content : c.*own; }
  double of(const LeafChromophores& c) const { return content ? c.contents.*content : c.*own; }
};
const std::array<LeafKey, std::size(kLeafContentKeys) + 3>& leaf_keys();
// Their names, in the same order (for the readers' unknown-key checks, materials/stack/json_keys.h).
const std::vector<const char*>& leaf_key_names();

}  // namespace lamina
