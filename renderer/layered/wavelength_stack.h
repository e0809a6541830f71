// The layered stack at a spectral path's three wavelengths (the spectral mode,
// docs/spectral.md, "Spectral rendering"): channel i of the stack the walk sees holds wavelength
// i's coefficients, so the walk, its hero channel and its spectral MIS run on wavelengths
// unchanged. A layer given by skin chromophores is evaluated at each wavelength
// (materials/spectral/chromophores.h); every other coefficient given in RGB (absorption, each
// lobe's scattering and g, a Lambert substrate's albedo) is uplifted by the basis of
// materials/spectral/uplift.h, a convex combination of its three channels at each wavelength, so
// it stays non-negative, g stays in (-1, 1) and a grey coefficient stays exactly what it is.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "materials/spectral/sampled_wavelengths.h"
#include "materials/stack/spectral_stack.h"
#include "materials/stack/stack.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/stack_bindings.h"

namespace lamina {

// `stack` at the wavelengths into *out (reusing its storage). chromophores: null, or the stack's
// file read with its chromophore layers kept, in the same orientation and layer order as `stack`.
void stack_at_wavelengths(const LayerStack& stack, const SpectralStack* chromophores, const SampledWavelengths& w,
                          LayerStack* out);

// The chromophore layers of `spectral` with the values `bindings` give at uv (the RGB mode's
// binding semantics, bound_chromophores in materials/stack/stack_parameters.h) into *out
// (reusing its storage); `bindings` is the material's, over the same file as `spectral`.
void bind_chromophores(const SpectralStack& spectral, const StackBindings& bindings, glm::dvec2 uv,
                       SpectralStack* out);

// Per glTF material slot, its file's chromophore layers (null: none, or not layered), read for the
// spectral mode. Throws std::runtime_error, one line naming the file, for what the spectral mode
// does not render yet: leaf layers (their index varies with the wavelength; a stack has one index
// per layer for all channels), chromophore layers in a stack that transmits.
std::vector<std::shared_ptr<const SpectralStack>> spectral_stacks(const LayeredBindings& bindings);

}  // namespace lamina
