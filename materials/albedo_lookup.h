// From a colour to stack parameters (issue 13 item 6, first part): the diffuse albedo of a stack
// over a grid of two parameters, and the parameters whose albedo is closest to a given colour.
//
// A photograph's texel gives (up to lighting, which a cross-polarised albedo texture removes)
// the diffuse albedo of the skin: the reflectance under uniform diffuse light,
// R_hemispherical of materials/adding_doubling.h. Two parameters of the stack (the skin's
// melanin and blood fractions, say) span a surface of albedos; a texel is mapped to the point of
// that surface nearest in CIE 1976 L*a*b* (the colour difference a viewer sees). Per texel
// fits would cost a forward solution per step per texel; the table costs nodes^2 solutions once
// and a lookup per texel (the "through a lookup table over the fitted parameters").
#pragma once

#include <vector>

#include "materials/adding_doubling.h"
#include "materials/stack_fit.h"

namespace lamina {

struct AlbedoLookup {
  std::vector<FitParameterSpec> axes;  // two scalar parameters with their ranges
  int nodes = 0;                       // per axis, evenly spaced from lower to upper
  std::vector<Spectrum> albedo;        // R_hemispherical at [i0 * nodes + i1]
  std::vector<Spectrum> lab;           // the same in L*a*b*
  // The albedo at unit coordinates (u0, u1) in [0, 1]^2, bilinear between the nodes.
  Spectrum at(double u0, double u1) const;
};

// Tabulates R_hemispherical of `t` with the two parameters of `axes` (paths as in
// stack_parameters.h, scalar ones: fractions, thicknesses) on a nodes x nodes grid. Throws
// FitError for a bad path, bounds or a colour parameter; nodes in [2, 1024].
AlbedoLookup build_albedo_lookup(const StackTemplate& t, const std::vector<FitParameterSpec>& axes, int nodes,
                                 const AddingDoublingSettings& settings = {});

struct AlbedoMatch {
  double value[2] = {0.0, 0.0};  // the two parameters
  Spectrum albedo;               // the table's albedo there
  double delta_e = 0.0;          // CIE76 colour difference from the target
};

// The parameters whose tabulated albedo is nearest `linear_rgb` in L*a*b*: the nearest node, then
// the minimum of Delta E over the table's bilinear surface from there (NLopt BOBYQA).
AlbedoMatch match_albedo(const AlbedoLookup& table, const Spectrum& linear_rgb);

// CIE 1976 L*a*b* of a linear Rec. 709 colour (D65 white, Y of white = 1; IEC 61966-2-1's
// matrix to XYZ, CIE 15:2004's L*a*b*), and the Euclidean difference of two colours (Delta E 76).
Spectrum linear_rgb_to_lab(const Spectrum& rgb);
double delta_e76(const Spectrum& lab_a, const Spectrum& lab_b);

}  // namespace lamina
