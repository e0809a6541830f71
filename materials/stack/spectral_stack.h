// A stack some of whose layers are given by chromophores (materials/spectral/chromophores.h) or
// by leaf contents (materials/spectral/leaf_chromophores.h): coefficients that depend on the
// wavelength. The renderer is RGB; such a stack is evaluated one
// wavelength at a time, as a grey stack (docs/spectral.md, "Skin chromophores").
#pragma once

#include <optional>
#include <vector>

#include "materials/spectral/chromophores.h"
#include "materials/spectral/leaf_chromophores.h"
#include "materials/stack/stack.h"

namespace lamina {

struct SpectralStack {
  // The layers as read; a chromophore layer's coefficients here are its values at 550 nm.
  LayerStack stack;
  // Per layer: its chromophores, or none for a layer given by grey coefficients (the same at
  // every wavelength; the reader rejects coloured ones).
  std::vector<std::optional<SkinChromophores>> chromophores;
  // Per layer: its leaf contents, or none (docs/spectral.md, "Layered leaf"); a leaf layer's
  // index is PROSPECT-D's at each wavelength.
  std::vector<std::optional<LeafChromophores>> leaves;
};

// The grey stack at one wavelength: each chromophore or leaf layer's sigma_a, sigma_s and g at nm
// (and a leaf layer's index).
LayerStack stack_at_wavelength(const SpectralStack& spectral, double nm);

// The same stack seen from below (flipped() in stack.h, its per-layer chromophores and leaf
// contents reversed with the layers). Only for a stack that transmits; throws
// std::invalid_argument otherwise.
SpectralStack flipped(const SpectralStack& spectral);

}  // namespace lamina
