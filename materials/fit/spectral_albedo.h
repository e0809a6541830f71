// From a colour to two chromophore parameters, spectrally (`lamina fit --albedo-texture` with a
// material given by chromophores; docs/fitting.md, "The spectral variant"). The forward model maps
// two chromophore parameters of the stack (the epidermis' melanin and the dermis' blood, say) to
// the colour the spectral film gives the stack's diffuse albedo spectrum: the albedo solved by
// adding-doubling at each wavelength of the colour grid (360-780 nm every 5 nm, each a grey
// stack), then projected onto linear Rec. 709 under D65 (rec709_channel_mean,
// materials/spectral/chromophores.h). The bound values enter the stack as the renderer's maps set
// them (bound_chromophores, materials/stack/stack_parameters.h: a volume fraction takes its change
// from the baseline), so the maps the fit writes give the renderer the fitted stack.
//
// The model is tabulated once on a nodes x nodes grid over the two parameters' ranges and
// interpolated bicubically (Catmull-Rom: C1, so a Newton step sees a continuous gradient, and
// an error falling with the cube of the spacing inside the grid); a texel is matched by
// Levenberg-Marquardt on the table from its nearest node, minimising the CIE76 difference in
// L*a*b* inside the parameters' box. A colour off the model's surface (most of a photograph's
// colours are: two parameters span a surface in a three-dimensional colour space) gets the
// nearest colour on it; one beyond the surface's edge (lighter than no melanin gives, say) gets
// parameters on the bound, which the caller counts as clamped.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/fit/albedo_lookup.h"
#include "materials/fit/stack_fit.h"
#include "materials/stack/spectral_stack.h"
#include "materials/stack/stack_parameters.h"

namespace lamina {

// The material read twice: as a template (what the parameters' paths resolve against and the
// bindings use) and with its chromophore layers kept per wavelength.
struct ChromophoreMaterial {
  StackTemplate stack;
  SpectralStack spectral;
};
ChromophoreMaterial load_chromophore_material(const std::string& path);

// True if both paths name chromophore parameters (layers[i].chromophores.KEY): the spectral
// variant of the albedo fit applies. Does not check the paths further.
bool chromophore_axes(const std::vector<FitParameterSpec>& axes);

// The checks of the table's axes: two chromophore parameters of `m` (parse_stack_parameter's
// resolution and messages) with finite, increasing bounds inside [0, the key's maximum]; throws
// FitError naming the path.
std::vector<StackParameter> check_spectral_albedo_axes(const ChromophoreMaterial& m, const std::vector<FitParameterSpec>& axes);

// The colour (linear Rec. 709, D65) of the stack's albedo of `kind` with the parameters `ps` set
// to `values` as bound by maps: one adding-doubling solution per wavelength of the colour grid.
Spectrum spectral_albedo_colour(const ChromophoreMaterial& m, const std::vector<StackParameter>& ps, const double* values,
                                AlbedoKind kind, const AddingDoublingSettings& settings);

struct SpectralAlbedoTable {
  std::vector<FitParameterSpec> axes;  // two chromophore parameters with their ranges
  AlbedoKind kind = AlbedoKind::kDiffuse;
  int nodes = 0;                       // per axis, evenly spaced from lower to upper
  std::vector<Spectrum> colour;        // linear Rec. 709 at [i0 * nodes + i1]
  std::vector<Spectrum> lab;           // the same in L*a*b*
  // The colour at unit coordinates (u0, u1) in [0, 1]^2, bicubic (Catmull-Rom) between the nodes.
  Spectrum at(double u0, double u1) const;
};

// Tabulates spectral_albedo_colour over the axes' ranges, nodes in [4, 257] per axis, nodes in
// parallel (TBB), each into its own place: the table does not depend on the threads. Cost: nodes^2
// x 85 one-wavelength solutions (docs/fitting.md gives the times).
SpectralAlbedoTable build_spectral_albedo_table(const ChromophoreMaterial& m, const std::vector<FitParameterSpec>& axes,
                                                int nodes, const AddingDoublingSettings& settings, AlbedoKind kind);

// The parameters whose tabulated colour is nearest `linear_rgb` in L*a*b* (the AlbedoMatch of
// materials/fit/albedo_lookup.h: values, the table's colour there, Delta E76).
AlbedoMatch match_spectral_albedo(const SpectralAlbedoTable& table, const Spectrum& linear_rgb);

// match_spectral_albedo for every texel of a linear RGB image (texels x 3 floats, interleaved),
// in parallel; each texel in its own place (the result does not depend on the threads).
AlbedoMapMatch match_spectral_albedo_map(const SpectralAlbedoTable& table, const float* rgb, std::size_t texels,
                                         const std::function<void(std::size_t)>& on_progress = {});

}  // namespace lamina
