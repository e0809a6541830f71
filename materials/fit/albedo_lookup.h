// From a colour to stack parameters: the diffuse albedo of a stack
// over a grid of two parameters, and the parameters whose albedo is closest to a given colour.
//
// A photograph's texel gives (up to lighting, which a cross-polarised albedo texture removes)
// the diffuse albedo of the skin: the reflectance under uniform diffuse light,
// R_hemispherical of materials/adding_doubling/adding_doubling.h. Two parameters of the stack (the skin's
// melanin and blood fractions, say) span a surface of albedos; a texel is mapped to the point of
// that surface nearest in CIE 1976 L*a*b* (the colour difference a viewer sees). Per texel
// fits would cost a forward solution per step per texel; the table costs nodes^2 solutions once
// and a lookup per texel (the "through a lookup table over the fitted parameters").
#pragma once

#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/fit/stack_fit.h"

namespace lamina {

// Which albedo the table holds. kDiffuse: the light that scattered in the stack, under uniform
// diffuse light, R_h - R_hs (diffuse_bihemispherical_albedo_adding_doubling, materials/tables/albedo.h):
// the renderer's Lambert albedo, and what a cross-polarised photograph records (the polariser
// removes the surface's specular reflection; the rendered stack adds it back itself). kTotal:
// R_hemispherical, the specular reflection of the interfaces included (~0.07 more for skin).
enum class AlbedoKind { kDiffuse, kTotal };

struct AlbedoLookup {
  std::vector<FitParameterSpec> axes;  // two scalar parameters with their ranges
  AlbedoKind kind = AlbedoKind::kDiffuse;
  int nodes = 0;                       // per axis, evenly spaced from lower to upper
  std::vector<Spectrum> albedo;        // the albedo of `kind` at [i0 * nodes + i1]
  std::vector<Spectrum> lab;           // the same in L*a*b*
  // The albedo at unit coordinates (u0, u1) in [0, 1]^2, bilinear between the nodes.
  Spectrum at(double u0, double u1) const;
};

// Two axes parsed on `t`: `admit` refuses an axis (throws FitError) or gives the range its bounds
// must lie in; a count other than two, bounds outside that range or not increasing, and a set
// that binds one value twice are one-line FitErrors.
using AxisAdmission = std::function<std::pair<double, double>(const FitParameterSpec&, const StackParameter&)>;
std::vector<StackParameter> parse_albedo_axes(const StackTemplate& t, const std::vector<FitParameterSpec>& axes,
                                              const AxisAdmission& admit);

// The checks of build_albedo_lookup's axes alone (cheap: no solution), and the parsed parameters.
std::vector<StackParameter> check_albedo_axes(const StackTemplate& t, const std::vector<FitParameterSpec>& axes);

// Tabulates the albedo of `kind` of `t` with the two parameters of `axes` (paths as in
// stack_parameters.h, scalar ones: fractions, thicknesses) on a nodes x nodes grid. Throws
// FitError for a bad path, bounds, a colour parameter or one rough_projection_refusal refuses
// (stack_fit.h); nodes in [2, 1024]. Rough interfaces, either model, are in the solution: the
// first node, solved alone, makes their projection, and the others reuse it. The nodes are
// solved in parallel (TBB), each into its own place: the table does not depend on the threads.
// On the rough energy-conserving oily skin (alpha 0.4, melanin 0-0.3, blood 0-0.2, 8 points,
// kDiffuse) the round trip of 20 random fractions is within 1.1% / 0.45% of each range at 17 /
// 33 nodes (tests/materials/fit/test_albedo_lookup.cpp).
//
// Error of the lookup (the bilinear interpolation's, falling with the square of the spacing), on
// the skin preset's melanin 0-0.3 and blood 0-0.2 at 8 quadrature points (kTotal), for colours on the
// stack's surface: at 20 random fractions in 5-95% of the ranges
// (tests/materials/fit/test_albedo_lookup.cpp) within 5.4% / 2.2% / 0.25% of each range with
// 9 / 17 / 33 nodes, Delta E under 1.4 / 0.3 / 0.05; on a 12 x 8 grid over 5-95% at 33 nodes
// (tests/renderer/cli/test_cli_fit.cpp) within 1.3% of the range and Delta E 0.14, the worst at
// melanin 5% of its range, where the albedo curves most. Where melanin is high the albedo barely
// depends on blood: the blood fraction there is ill-conditioned (an 8-bit sRGB rounding of the
// colour, Delta E < 0.7, moves it by up to 0.69 of its range).
AlbedoLookup build_albedo_lookup(const StackTemplate& t, const std::vector<FitParameterSpec>& axes, int nodes,
                                 const AddingDoublingSettings& settings, AlbedoKind kind);

struct AlbedoMatch {
  double value[2] = {0.0, 0.0};  // the two parameters
  Spectrum albedo;               // the table's albedo there
  double delta_e = 0.0;          // CIE76 colour difference from the target
};

// The parameters whose tabulated albedo is nearest `linear_rgb` in L*a*b*: the nearest node, then
// the minimum of Delta E over the table's bilinear surface from there (NLopt BOBYQA).
AlbedoMatch match_albedo(const AlbedoLookup& table, const Spectrum& linear_rgb);

// match_albedo for every texel of a linear RGB image (`rgb`: texels x 3 floats, interleaved),
// texels in parallel (TBB), each result in its own place, so the maps do not depend on the
// number of threads. on_progress (optional, thread-safe) receives the texels done per block.
struct AlbedoMapMatch {
  std::vector<double> value[2];  // per texel, the two parameters
  std::vector<Spectrum> albedo;  // per texel, the table's albedo there
  std::vector<double> delta_e;   // per texel, CIE76 colour difference from the texel
};
// Every texel of `rgb` matched on its own by `match` (in parallel; on_progress gets the texels done).
AlbedoMapMatch match_albedo_map_by(const std::function<AlbedoMatch(const Spectrum&)>& match, const float* rgb,
                                   std::size_t texels, const std::function<void(std::size_t)>& on_progress);

AlbedoMapMatch match_albedo_map(const AlbedoLookup& table, const float* rgb, std::size_t texels,
                                const std::function<void(std::size_t)>& on_progress = {});

// Mean, median, 95th percentile (nearest rank: the smallest value with at least 95% of the
// values at or below it) and maximum of a set of colour differences, and how many exceed
// `threshold`. Summed in order: the same for the same values. Empty: all zero.
struct DeltaEStatistics {
  double mean = 0.0, median = 0.0, p95 = 0.0, max = 0.0;
  std::size_t above = 0;
};
DeltaEStatistics delta_e_statistics(std::vector<double> delta_e, double threshold);

// CIE 1976 L*a*b* of a linear Rec. 709 colour (D65 white, Y of white = 1; IEC 61966-2-1's
// matrix to XYZ, CIE 15:2004's L*a*b*), and the Euclidean difference of two colours (Delta E 76).
Spectrum linear_rgb_to_lab(const Spectrum& rgb);
double delta_e76(const Spectrum& lab_a, const Spectrum& lab_b);

}  // namespace lamina
