// Stack parameters: one number (or colour) of a material file, addressed by its JSON path, that
// the renderer changes per shading point (a texture drives the blood volume fraction of the
// dermis, the melanin of the epidermis, the thickness of an oily film).
//
// Changing a parameter must be cheap (no JSON per hit), so a material file is loaded once into
// a StackTemplate: the compiled LayerStack plus the description it was mixed from (each layer's
// components with their volume fractions and own coefficients, docs/contracts.md "Material file").
// A path is resolved once into a StackParameter; apply_parameters() then copies the template's
// stack and re-mixes only the layers whose parameters were set.
//
// Addressable paths (N layers, M components in a layer):
//   layers[i].thickness            scalar, >= 0 (not on an "inf" layer)
//   layers[i].ior                  scalar, > 0
//   layers[i].sigma_a|sigma_s|g    colour, of a layer given directly (no components)
//   layers[i].components[j].fraction           scalar in [0, 1]; needs M >= 2
//   layers[i].components[j].sigma_a|sigma_s|g  colour
//   layers[i].chromophores.KEY     scalar, of a layer given by chromophores (KEY one of
//                                  chromophore_keys(): melanin, blood, ...); the layer's RGB
//                                  sigma_a is recomputed from its chromophores with the value set
//   layers[i].leaf.KEY             scalar, of a layer given by leaf contents (KEY one of
//                                  leaf_keys(): chlorophyll, ..., plates, scattering_power, g);
//                                  read by the spectral mode alone (bound_leaf): the stack's
//                                  leaf layer keeps the file's placeholders at 550 nm
//   below.lambert                  colour in [0, 1] (a Lambert substrate)
//   below.ior                      scalar, > 0 (a dielectric below)
//
// Fractions stay a partition of the layer: setting component j to f scales the others by
// (1 - f) / (1 - w_j), with w_j the template's fraction, so their proportions are kept and the
// sum stays 1. If the others had zero total fraction in the template, they share 1 - f equally.
// Values outside a parameter's physical range are clamped to it (a freckle added on top of a
// map can overshoot): fraction to [0, 1], coefficients to >= 0, |g| to <= 1 - 1e-6, thickness to
// >= 0, ior to >= 1e-6, Lambert albedo to [0, 1], a chromophore to [0, its max_value()] (a volume
// fraction so that the layer's fractions still sum to at most 1), a leaf key to its range.
#pragma once

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "materials/base/spectrum.h"
#include "materials/spectral/chromophores.h"
#include "materials/spectral/leaf_chromophores.h"
#include "materials/stack/stack.h"

namespace lamina {

// One component of a layer as written in the file. A layer given directly (sigma_a, sigma_s,
// g) is one component of fraction 1.
struct ComponentDesc {
  double fraction = 1.0;
  Spectrum sigma_a;
  Spectrum sigma_s;
  Spectrum g;
};

struct LayerDesc {
  bool composite = false;  // true: the file gave "components"; false: sigma_a, sigma_s, g
  std::vector<ComponentDesc> components;
  // A layer given by chromophores: them (its one component holds their RGB coefficients).
  std::optional<SkinChromophores> chromophores;
  // A layer given by leaf contents (a spectral file, load_spectral_stack_template): them.
  std::optional<LeafChromophores> leaf;
};

// A compiled stack and the description it was mixed from; layers[i] describes stack.layers[i].
struct StackTemplate {
  LayerStack stack;
  std::vector<LayerDesc> layers;
};

struct StackParameterError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct StackParameter {
  enum class Kind { kThickness, kIor, kSigmaA, kSigmaS, kG, kFraction, kBelowLambert, kBelowIor, kRoughness,
                    kChromophore, kLeaf };
  std::string path;  // as given, for messages
  Kind kind = Kind::kThickness;
  int layer = -1;      // -1 for below.*
  int component = -1;  // -1 for a whole-layer parameter
  int chromophore = -1;  // kChromophore: the index into chromophore_keys()
  double chromophore_max = 1.0;  // kChromophore: its largest value in this stack
  int leaf_key = -1;  // kLeaf: the index into leaf_keys()
  // True if the parameter is a colour (sigma_a, sigma_s, g, lambert); false for a scalar.
  bool spectral() const;
  // The physical range of one channel (used to check binding ranges at load time).
  double min_value() const;
  double max_value() const;  // +infinity where unbounded
  // The template's value (a scalar as a grey triple).
  Spectrum template_value(const StackTemplate& t) const;
};

// Resolves `path` against the template. Throws StackParameterError("PATH: reason"), e.g.
// "layers[5].thickness: the stack has 3 layers (layers[0] .. layers[2])".
StackParameter parse_stack_parameter(const StackTemplate& t, const std::string& path);

// out = the template's stack with parameters[k] set to values[k] (a scalar parameter reads
// values[k][0]). Parameters are applied in order; at most one fraction per layer may be set
// (check_parameter_set). `out` is overwritten; reusing the same `out` across calls reuses its
// storage, so this does not allocate after the first call.
void apply_parameters(const StackTemplate& t, const std::vector<StackParameter>& parameters,
                      const Spectrum* values, LayerStack* out);

// Layer l's chromophores (a layer given by chromophores) with the kChromophore parameters naming
// it set to their values, clamped as apply_parameters does; a bound volume fraction takes its
// change from the baseline. apply_parameters sets the layer's sigma_a from these (RGB); the
// spectral mode evaluates them at its wavelengths.
SkinChromophores bound_chromophores(const StackTemplate& t, const std::vector<StackParameter>& parameters,
                                    const Spectrum* values, int l);

// Layer l's leaf contents (a layer given by leaf contents) with the kLeaf parameters naming it set
// to their values, clamped to their keys' ranges (g to |g| <= 1 - 1e-6). The spectral mode
// evaluates them at its wavelengths; apply_parameters leaves the RGB placeholders alone.
LeafChromophores bound_leaf(const StackTemplate& t, const std::vector<StackParameter>& parameters,
                            const Spectrum* values, int l);

// Throws StackParameterError if the set is ambiguous: the same path twice, or two fractions of
// one layer (each would renormalise the other away).
void check_parameter_set(const std::vector<StackParameter>& parameters);

// Mixes a layer's components into its absorption and phase lobes (docs/contracts.md: sigma_a =
// sum w_i sigma_a_i, sigma_s p = sum w_i sigma_s_i p(g_i); Hanrahan and Krueger eq. 8).
void mix_layer(const LayerDesc& desc, Layer* layer);

// The syntax of a path alone, without a stack to resolve it against: what a batch manifest's
// "set" addresses (docs/batch.md), where any value of a material file may be changed, not only
// the parameters above. Keys are separated by '.', indices are "[n]" with 1 to 6 digits, and
// the '.' after an index may be left out: "layers[1].components[0].fraction" is layers, [1],
// components, [0], fraction. Every path parse_stack_parameter accepts is one of these.
struct StackPathStep {
  std::string key;        // empty for an index
  std::size_t index = 0;  // the index, when key is empty
};
// Throws StackParameterError("PATH: reason") for an empty or malformed path.
std::vector<StackPathStep> split_stack_path(const std::string& path);

// The value at `steps` in a material file's JSON, `path` being the text they were split from.
// Throws StackParameterError("'PATH': reason") when the file has no such value, e.g.
// "'layers[7].thickness': 'layers' has 2 entries, no [7]".
nlohmann::json* find_stack_value(nlohmann::json& stack, const std::vector<StackPathStep>& steps, const std::string& path);

}  // namespace lamina
