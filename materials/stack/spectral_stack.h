// A stack some of whose layers are given by chromophores (materials/spectral/chromophores.h):
// coefficients that depend on the wavelength. The renderer is RGB; such a stack is evaluated one
// wavelength at a time, as a grey stack (docs/spectral.md, "Skin chromophores").
#pragma once

#include <optional>
#include <vector>

#include "materials/spectral/chromophores.h"
#include "materials/stack/stack.h"

namespace lamina {

struct SpectralStack {
  // The layers as read; a chromophore layer's coefficients here are its values at 550 nm.
  LayerStack stack;
  // Per layer: its chromophores, or none for a layer given by grey coefficients (the same at
  // every wavelength; the reader rejects coloured ones).
  std::vector<std::optional<SkinChromophores>> chromophores;
};

// The grey stack at one wavelength: each chromophore layer's sigma_a, sigma_s and g at nm.
LayerStack stack_at_wavelength(const SpectralStack& spectral, double nm);

}  // namespace lamina
