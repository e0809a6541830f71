// PROSPECT-D: a leaf as a pile of N absorbing plates (Jacquemoud and Baret 1990, Remote Sens.
// Environ. 34:75; Feret, Gitelson, Noble and Jacquemoud 2017, Remote Sens. Environ. 193:204).
// Its total (directional-hemispherical) reflectance and transmittance for light incident within a
// cone of half-angle 40 degrees, from the leaf's pigment, water and dry-matter contents and the
// specific absorption coefficients of dataSpec_PDB.m (materials/spectral/prospect_d_data.cpp).
// Derivations: docs/spectral.md, "PROSPECT-D".
#pragma once

#include <vector>

#include "materials/spectral/tabulated_spectrum.h"

namespace lamina {

// What a leaf (or one layer of it) holds per unit leaf area, the absorbers of PROSPECT-D. The
// layered leaf (materials/spectral/leaf_chromophores.h) gives one per layer, defaults 0.
struct LeafContents {
  double chlorophyll = 0.0;   // chlorophyll a+b, ug/cm2
  double carotenoids = 0.0;   // ug/cm2
  double anthocyanins = 0.0;  // ug/cm2
  double brown = 0.0;         // brown pigments, arbitrary units
  double water = 0.0;         // equivalent water thickness, cm (g/cm2)
  double dry_matter = 0.0;    // leaf mass per area, g/cm2
};

// The model's parameters with their units (per unit leaf area). Defaults: a mature green leaf.
struct ProspectParameters : LeafContents {
  ProspectParameters() : LeafContents{40.0, 8.0, 0.0, 0.0, 0.01, 0.009} {}
  double n = 1.5;  // structure: the number of plates (>= 1, real)
};

struct PlateOptics {
  double reflectance = 0.0;
  double transmittance = 0.0;
};

// The wavelengths of the coefficients: 400-2500 nm every 1 nm.
WavelengthGrid prospect_grid();

// Stern (1964) and Allen (1973): the transmissivity of a smooth dielectric plane (relative index
// n) averaged over isotropic light incident within a cone of half-angle alpha (degrees) about
// the normal, both polarisations. alpha = 90 is the hemispherical average.
double average_transmissivity(double alpha_degrees, double n);

// The transmission of one plate's absorbing interior for isotropic (diffuse) light crossing a
// layer of absorption optical thickness k (Allen et al. 1969): (1 - k) e^-k + k^2 E1(k).
double diffuse_transmission(double k);

// One compact plate of index n whose interior transmits tau of the diffuse light crossing it:
// (Allen, Gausman, Richardson and Thomas 1969). `incident` for light from within the cone alpha
// (the leaf's first plate), otherwise for isotropic light (the plates below it).
PlateOptics plate(double alpha_degrees, double n, double tau, bool incident);

// Stokes (1862): N - 1 plates, each (r, t), piled with their multiple reflections; N real >= 1.
PlateOptics stokes_pile(const PlateOptics& one, double plates);

// The leaf at one wavelength of the table (400-2500 nm; coefficients interpolated linearly
// between the table's nanometres, held beyond its ends).
PlateOptics prospect_d(const ProspectParameters& p, double nm);

// Absorption coefficient sum (cab Kab + car Kcar + ant Kant + brown Kbrown + cw Kw + cm Km) of the
// whole leaf at one wavelength, before it is shared among the N plates: the optical thickness
// of absorption along the normal (a plate's interior transmits e^(-K/mu) in direction mu).
double prospect_d_absorption(const LeafContents& p, double nm);

// The refractive index of the leaf material (PROSPECT-D's nr).
double prospect_refractive_index(double nm);

// Throws std::invalid_argument naming the first parameter out of its domain.
void validate(const ProspectParameters& p);

}  // namespace lamina
