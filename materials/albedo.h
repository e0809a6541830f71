// The diffuse albedo of a layer stack: the `lambert` shading mode's Lambert albedo, and auto's
// lambert model (renderer/layered/layered_material.h caches it per material).
#pragma once

#include <cstdint>

#include "materials/spectrum.h"
#include "materials/stack.h"

namespace lamina {

// The diffuse bihemispherical reflectance of a stack by `walks` random walks with cosine-weighted
// incidence (mu_i = sqrt(u): density 2 mu_i on [0,1], so the walks' mean top exit weight after
// >= 1 scattering is 2 int R_diffuse(mu) mu dmu). Deterministic: walk i uses Rng(seed, i).
Spectrum diffuse_bihemispherical_albedo(const LayerStack& stack, int walks, std::uint64_t seed,
                                        Spectrum* standard_error = nullptr);

}  // namespace lamina
