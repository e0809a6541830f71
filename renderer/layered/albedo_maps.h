// From a colour texture to parameter maps (`lamina fit --albedo-texture`,
// docs/contracts.md): the texture as linear RGB, every texel matched through the albedo lookup
// (materials/fit/albedo_lookup.h: the physics), and the content of the outputs:
//   - one parameter map per lookup axis: a 16-bit grey PNG storing t = (value - lower) /
//     (upper - lower) linearly (no transfer function), so that a binding with
//     "range": [lower, upper] gives the value back (docs/stack_bindings.md, "Maps are data");
//   - a `lamina render --materials` map binding them to the stack;
//   - the matched albedo as an 8-bit sRGB PNG (to set beside the texture);
//   - the report (JSON): the colour difference against the texture, the texels the two
//     parameters cannot reach, the parameters' statistics, the times.
// Writing the files (all or none) is the command line's part.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "materials/fit/albedo_lookup.h"
#include "materials/stack/stack_parameters.h"
#include "renderer/image/image.h"
#include "renderer/image/image_io.h"

namespace lamina {

struct AlbedoMapsSettings {
  std::vector<FitParameterSpec> axes;  // two scalar parameters and their ranges
  int nodes = 33;                      // lookup nodes per axis
  int quadrature_points = 8;           // adding-doubling points of the lookup's solutions
  AlbedoKind albedo = AlbedoKind::kDiffuse;  // which albedo the texture is (materials/fit/albedo_lookup.h)
  // A texel whose match is farther than this (CIE76) is counted as not reachable by the two
  // parameters. 2.3 is the just-noticeable difference (Mahy et al. 1994); the lookup's own
  // error is far below it (0.05 at 33 nodes).
  double unreachable_delta_e = 2.3;
};

struct AlbedoMapsResult {
  int width = 0, height = 0;
  AlbedoMapMatch match;  // per texel, row major from the top left
  DeltaEStatistics delta_e;
  std::size_t at_lower[2] = {0, 0}, at_upper[2] = {0, 0};  // texels at a bound of each axis
  double lookup_seconds = 0.0, matching_seconds = 0.0;
};

// Throws ImageIoError naming `path` and the first texel (x, y) that is not finite.
void check_albedo_texture(const Image& texture, const std::string& path);

// Builds the lookup of `stack` and matches every texel of `texture` (linear RGB). Throws
// FitError for a bad axis (path, bounds, a colour parameter). on_lookup_built (optional) is
// called between the two parts; on_progress (optional, thread-safe) receives texels done.
AlbedoMapsResult fit_albedo_maps(const StackTemplate& stack, const Image& texture, const AlbedoMapsSettings& settings,
                                 const std::function<void()>& on_lookup_built = {},
                                 const std::function<void(std::size_t)>& on_progress = {});

// r->delta_e and the texels at each axis's bounds (to 1e-6 of the range) from r->match.
void summarise_albedo_match(const AlbedoMapsSettings& settings, AlbedoMapsResult* r);

// The file name of an axis's parameter map: its path without brackets, "layers[1].thickness" ->
// "layers1.thickness.png".
std::string parameter_map_file_name(const std::string& path);
// The stored values t in [0, 1] of axis `axis`'s map, row major.
std::vector<float> parameter_map_values(const AlbedoMapsResult& result, const AlbedoMapsSettings& settings, int axis);
// The matched albedo as an image (linear RGB).
Image fitted_albedo_image(const AlbedoMapsResult& result);

// The `lamina render --materials` map: {material: {"stack": STACK, "bind": [one per axis]}},
// `stack_reference` as it is to be written (relative to the map's directory or absolute).
std::string albedo_materials_map_json(const std::string& material, const std::string& stack_reference,
                                      const AlbedoMapsSettings& settings);

// The report. `inputs` names the files and choices as given (texture, decoding, stack, material,
// output files), for the record.
struct AlbedoMapsInputs {
  std::string texture, texture_decoding, stack, material, materials_map, fitted_albedo;
  int threads = 0;
  double total_seconds = 0.0;
};
std::string albedo_maps_report_json(const AlbedoMapsResult& result, const AlbedoMapsSettings& settings,
                                    const AlbedoMapsInputs& inputs);

}  // namespace lamina
