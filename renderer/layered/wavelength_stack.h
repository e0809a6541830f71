// The layered stack at a spectral path's three wavelengths (the spectral mode,
// docs/spectral.md, "Spectral rendering"): channel i of the stack the walk sees holds wavelength
// i's coefficients, so the walk, its hero channel and its spectral MIS run on wavelengths
// unchanged. A layer given by skin chromophores is evaluated at each wavelength
// (materials/spectral/chromophores.h); every other coefficient given in RGB (absorption, each
// lobe's scattering and g, a Lambert substrate's albedo) is uplifted by the basis of
// materials/spectral/uplift.h, a convex combination of its three channels at each wavelength, so
// it stays non-negative, g stays in (-1, 1) and a grey coefficient stays exactly what it is.
// A leaf layer (materials/spectral/leaf_chromophores.h) has PROSPECT-D's index at each
// wavelength, and a stack has one index per layer: where the path's three wavelengths would
// refract into three directions, the path follows one of them alone (stack_at_wavelength_channel;
// the estimator is derived in docs/spectral.md, "Leaves: one wavelength through a leaf").
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "materials/spectral/sampled_wavelengths.h"
#include "materials/stack/spectral_stack.h"
#include "materials/stack/stack.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/stack_bindings.h"

namespace lamina {

// `stack` at the wavelengths into *out (reusing its storage). chromophores: null, or the stack's
// file read with its chromophore and leaf layers kept, in the file's layer order; from_below:
// `stack` is that file's stack flipped (seen from below: layer i is the file's layer N-1-i).
// A leaf layer keeps the index it has in `stack` (one per layer): stack_at_wavelength_channel
// gives it its own.
void stack_at_wavelengths(const LayerStack& stack, const SpectralStack* chromophores, bool from_below,
                          const SampledWavelengths& w, LayerStack* out);

// The stack at the path's wavelength `channel` alone, in every channel (a grey stack: the walk's
// channels are then equal), each leaf layer with PROSPECT-D's index at that wavelength. For
// stacks whose index varies with the wavelength (has_leaf_layers).
void stack_at_wavelength_channel(const LayerStack& stack, const SpectralStack* chromophores, bool from_below,
                                 const SampledWavelengths& w, int channel, LayerStack* out);

// Whether a layer's index varies with the wavelength (a leaf layer): a path then follows one
// wavelength through the stack.
bool has_leaf_layers(const SpectralStack& spectral);

// The stack of a material file with leaf layers, as the spectral mode reads it (coefficients and
// indices at 550 nm until stack_at_wavelengths sets them), as a template whose leaf layers keep
// their contents for maps (layers[i].leaf.KEY): the RGB reader refuses leaf layers.
// nullopt if the file has no leaf layer or is not a readable material file (the RGB reader's
// error then stands).
std::optional<StackTemplate> leaf_stack(const std::string& path);

// The chromophore and leaf layers of `spectral` with the values `bindings` give at uv (the RGB
// mode's binding semantics, bound_chromophores, and bound_leaf, in
// materials/stack/stack_parameters.h) into *out (reusing its storage); `bindings` is the
// material's, over the same file as `spectral`.
void bind_chromophores(const SpectralStack& spectral, const StackBindings& bindings, glm::dvec2 uv,
                       SpectralStack* out);

// Per glTF material slot, its file's chromophore and leaf layers (null: none, or not layered),
// read for the spectral mode.
std::vector<std::shared_ptr<const SpectralStack>> spectral_stacks(const LayeredBindings& bindings);

}  // namespace lamina
