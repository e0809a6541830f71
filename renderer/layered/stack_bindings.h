// Texture-driven stack parameters: maps and generated freckles that set parameters of a layered
// material per shading point, so that maps drive the physics (blood volume fraction in the
// dermis, melanin in the epidermis, the thickness of an oily film).
//
// Schema (docs/stack_bindings.md), in a glTF material's extras under "lamina" or in a
// `--materials` map entry:
//   { "stack": "skin_oily.json",
//     "bind": [ { "parameter": "layers[2].components[0].fraction",
//                 "texture": "blood.png" | 3,          (a file, or a glTF texture index)
//                 "channel": "r" | "g" | "b" | "a" | "luminance" | "rgb",
//                 "range": [0.005, 0.05] } ],          (value at channel 0 and at channel 1)
//     "freckles": { "parameter": "layers[1].components[0].fraction",
//                   "density": 400, "radius": 0.004, "amplitude": 0.08, "seed": 7,
//                   "mask": { "texture": "mask.png", "channel": "r" } } }      (mask optional)
//
// Parameter maps are DATA, not colour: a file is read with its stored values (0..255 -> 0..1,
// no sRGB decoding; EXR values as stored); a glTF texture index names a texture the loader has
// decoded from sRGB, which is re-encoded here (srgb_encode is its exact inverse up to float
// rounding, ~1e-7), so both give the stored values. The channel value t is clamped to [0, 1]
// and mapped linearly: value = range[0] + (range[1] - range[0]) t (range[0] > range[1] inverts
// the map). For a colour parameter (sigma_a, sigma_s, g, lambert) the range ends may be colours
// [r, g, b]; "rgb" drives each channel by its own texture channel. "luminance" is
// 0.2126 r + 0.7152 g + 0.0722 b of the stored values. Lookups are bilinear; files clamp at
// the edges, glTF textures follow their sampler.
//
// Freckles: spots of parameter variation added on top of the parameter's value (its map, or
// the stack's own value). A Poisson process of `density` spots per unit area of UV space; spot
// k at c_k adds a_k w(|uv - c_k|) with a_k = amplitude (0.5 + 0.5 U_k) (U uniform: spots vary
// in strength) and the truncated Gaussian profile
//   w(d) = (exp(-d^2 / 2 r^2) - e^-4.5) / (1 - e^-4.5) for d < 3r, else 0
// (continuous at the cut, 1 at the centre). UV space is tiled by n x n cells of side 1/n >= 3r,
// periodic in u and v, with Poisson(density / n^2) spots per cell drawn from Rng(seed, cell):
// a spot affects only its cell's 3 x 3 neighbourhood, so evaluation is O(1) and deterministic.
// A negative amplitude makes pale spots. The optional mask (a map, stored value in [0, 1])
// multiplies the freckles (e.g. cheeks and nose only). The result is clamped to the
// parameter's physical range (stack_parameters.h).
#pragma once

#include <algorithm>
#include <cmath>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <nlohmann/json_fwd.hpp>

#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"
#include "materials/stack/stack_parameters.h"

namespace lamina {

struct SceneDesc;

// A data texture: stored values in [0, 1] (or as stored, for float files), 1 to 4 channels.
struct ParameterMap {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> values;  // row-major from the top row, `channels` floats per texel
  bool clamp_s = true;
  bool clamp_t = true;
  // Bilinear lookup of channel c (texel centres at (i + 0.5) / width, as Texture::lookup).
  double lookup(glm::dvec2 uv, int channel) const;
};

// Nodes for a piecewise-linear model over a map's texel values t (each in [0, 1]): at most `count`
// increasing values from min(t) to max(t) (one if they are all equal), placed greedily so that
// sum over texels (t - a)(b - t), with [a, b] the texel's interval, falls fastest: the error of
// linear interpolation between nodes for a model of even curvature, weighted by how many texels
// see it. Nodes crowd where the texels are (a face's melanin map is mostly near 0, with eyebrows
// far above it), instead of spreading evenly over the binding's range. Deterministic.
std::vector<double> map_nodes(const std::vector<double>& t, int count);

// Reads an image file's stored values (no colour conversion). Throws SceneError naming it.
ParameterMap read_parameter_map(const std::string& path);

struct Freckles {
  double density = 0.0;    // spots per unit area of UV space
  double radius = 0.01;    // Gaussian sigma r in UV units
  double amplitude = 0.0;  // parameter change at the centre of the strongest spot
  std::uint64_t seed = 0;
  int cells = 1;  // n: cells of side 1/n >= 3r per UV unit
  // The freckle field at uv: sum_k a_k w(|uv - c_k|) (periodic in u and v).
  double value(glm::dvec2 uv) const;
  // Sets `cells` from radius; throws std::invalid_argument if radius is not in (0, 1/6] or the
  // mean spot count per cell would exceed 64 (density far too high for the radius). Then draws
  // every cell's spots once into a table if there are at most `max_tabulated` cells and spots
  // expected (a face's freckles: 83 x 83 cells, 2,500 spots; 24 bytes a spot); beyond that
  // value() draws the spots of the nine cells around each point again (the same spots, bit for
  // bit: a per-hit cost instead of memory).
  static constexpr double kMaxTabulated = 1 << 20;
  void prepare(double max_tabulated = kMaxTabulated);
  bool tabulated() const { return !cell_start_.empty(); }

  // One spot: its offset in its cell (in cells, [0, 1)) and its strength a_k.
  struct Spot {
    double x, y, amplitude;
  };

 private:
  // Calls visit(spot) for each spot of cell (wx, wy) (indices in [0, cells)), drawn from the
  // cell's own random stream.
  template <class Visit>
  void draw_cell(int wx, int wy, const Visit& visit) const;
  std::vector<std::uint32_t> cell_start_;  // the table: cell c's spots are
  std::vector<Spot> spots_;                //   spots_[cell_start_[c], cell_start_[c + 1])
};

// The integral of the spot profile over the plane, int w dA = 2 pi r^2 (1 - e^-4.5 (1 + 4.5))
// / (1 - e^-4.5): the freckles' mean over UV is density * E[a_k] * this (Campbell's theorem).
double freckle_profile_integral(double radius);

// A material's bindings, ready to evaluate per hit.
// Room for a material's parameter values at one hit: a fixed array for the usual handful (no
// allocation per hit), a vector beyond that.
class ParameterValues {
 public:
  explicit ParameterValues(std::size_t n) {
    if (n > kInline) large_.resize(n);
  }
  Spectrum* data() { return large_.empty() ? small_ : large_.data(); }

 private:
  static constexpr std::size_t kInline = 16;
  Spectrum small_[kInline];
  std::vector<Spectrum> large_;
};

class StackBindings {
 public:
  // Parses the "bind" and "freckles" members of `spec` (other members are ignored here; the
  // caller handles "stack"). Relative texture paths resolve against base_file's directory.
  // Errors: SceneError("NAMED_IN: material 'M': bind[1].range: ..."), one line.
  StackBindings(const nlohmann::json& spec, std::shared_ptr<const StackTemplate> stack, const SceneDesc& scene,
                const std::string& named_in, const std::string& material, const std::string& base_file);

  bool empty() const { return parameters_.empty(); }
  // Writes the stack at uv into *out (reusing its storage).
  void evaluate(glm::dvec2 uv, LayerStack* out) const;
  // The parameter values at uv, one per parameter() (for tests and tools).
  void values(glm::dvec2 uv, Spectrum* out) const;
  const std::vector<StackParameter>& parameters() const { return parameters_; }
  // The values parameter k takes over the surface: a binding's range (its two ends, in order),
  // widened by the freckles' amplitude for the freckle parameter; the template's value for a
  // parameter only the freckles drive, plus [0, amplitude].
  void value_range(std::size_t k, Spectrum* lo, Spectrum* hi) const;
  // The nodes of the separable models along parameter k (the lambert mode's albedo factors,
  // LayeredMaterial::lambert_albedo_at; the table mode's parameter tables, LayeredTables), and
  // the channel of the widest range, whose value places a hit between them. A parameter driven
  // by a map alone gets `count` nodes where its texels are (map_nodes: from the smallest to the
  // largest texel value, placed to minimise the texels' interpolation error); one the freckles
  // drive, `count` values evenly over value_range. One node if it is constant over the surface.
  struct Nodes {
    int channel = 0;
    std::vector<Spectrum> values;  // increasing in `channel`
    bool even = true;              // evenly spaced (bracket's arithmetic shortcut)
    // A parameter driven by a map alone: which map and channel drive it (parameters with the same
    // source move together, at the same map values t), the nodes' map values (values[j] at t[j]),
    // and the node nearest the texels' median map value. Empty source otherwise.
    std::string source;
    std::vector<double> t;
    std::size_t central = 0;
    // Where a hit's value x (of `channel`) falls: between node j and j + 1 with weight t on
    // j + 1, clamped at the ends (at least two nodes).
    void bracket(double x, std::size_t* j, double* t) const;
  };
  Nodes nodes(std::size_t k, int count) const;
  const StackTemplate& stack_template() const { return *template_; }
  // The map value driving channel c of parameter k at every texel of its map (empty for a
  // parameter only the freckles drive).
  std::vector<double> texel_values(std::size_t k, int c) const;
  // The bound maps, for checks (their paths, resolved; empty for glTF textures).
  const std::vector<std::string>& map_files() const { return map_files_; }

 private:
  struct Source {
    std::shared_ptr<const ParameterMap> map;
    int channel = 0;  // 0..3, kLuminance, or kRgb
    bool srgb_encoded = false;  // a glTF texture decoded by the loader: re-encode
    std::string key;            // the file or glTF texture, and the channel
    double sample(glm::dvec2 uv, int c) const;  // the value driving colour channel c
    std::vector<double> texel_values(int c) const;  // sample's value at every texel's centre
    // The value driving colour channel c from the map's channels as `get` reads them (a
    // bilinear lookup, or one texel): the bound channel, luminance or the matching RGB channel,
    // clamped to [0, 1] (0 if not finite).
    template <class Get>
    double driving_value(Get get, int c) const;  // defined in stack_bindings.cpp, its one user
  };
  struct Binding {
    Source source;
    Spectrum lo, hi;
  };
  Source parse_source(const nlohmann::json& j, const std::string& where, bool allow_rgb);

  std::shared_ptr<const StackTemplate> template_;
  const SceneDesc* scene_ = nullptr;
  std::string named_in_, material_, base_file_;
  std::vector<StackParameter> parameters_;  // bound parameters, then the freckles' if not bound
  std::vector<Binding> bindings_;           // bindings_[k] drives parameters_[k]
  bool has_freckles_ = false;
  Freckles freckles_;
  int freckle_parameter_ = -1;  // index in parameters_
  bool has_mask_ = false;
  Source mask_;
  std::vector<std::string> map_files_;
};

}  // namespace lamina
