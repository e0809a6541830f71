// The diffuse albedo of a layer stack: the `lambert` shading mode's Lambert albedo, and auto's
// lambert model (renderer/layered/layered_material.h caches it per material).
#pragma once

#include <cstdint>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/walk/random_walk.h"
#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

// The diffuse bihemispherical reflectance of a stack by `walks` random walks with cosine-weighted
// incidence (mu_i = sqrt(u): density 2 mu_i on [0,1], so the walks' mean top exit weight after
// >= 1 scattering is 2 int R_diffuse(mu) mu dmu). Deterministic: walk i uses Rng(seed, i).
// settings: the walk's (e.g. an approximate similarity_after, to measure its bias).
Spectrum diffuse_bihemispherical_albedo(const LayerStack& stack, int walks, std::uint64_t seed,
                                        Spectrum* standard_error = nullptr, const WalkOptions& settings = {});

// The same albedo without noise, by adding-doubling: 2 int_0^1 R_diffuse(mu) mu dmu = R_h - R_hs,
// with R_h the total reflectance for uniform diffuse incidence (adding_doubling_totals, one
// solution; it includes the unscattered light) and R_hs = 2 int R_specular(mu) mu dmu the
// unscattered part (materials/analytic/zeroth_order, exact, by Gauss-Legendre quadrature in mu on the
// segments between the critical cosines, where R_specular has kinks). Under a rough top R_hs is
// the hemispherical of the top's own (glossy) reflection, from the same solution
// (AddingDoublingTotals::R_hemispherical_glossy); light that entered through the rough top and
// left without scattering (reflected by an inner interface) counts as diffuse here, where the
// walk's estimate leaves it out.
// `settings`: R_h's solution (the default 16 points; R_hs is exact for a smooth top).
Spectrum diffuse_bihemispherical_albedo_adding_doubling(const LayerStack& stack, const AddingDoublingSettings& settings = {});

// The bias of an approximate walk (settings, e.g. similarity_after) on that albedo: the mean and
// standard error of (approximate - exact) over paired walks that share their random numbers
// (walk i of both from Rng(seed, i): identical until the approximation starts, so the pairs'
// differences are far less noisy than either estimate). *exact: the exact albedo of these walks.
Spectrum diffuse_albedo_bias(const LayerStack& stack, const WalkOptions& approximate, int walks, std::uint64_t seed,
                             Spectrum* standard_error, Spectrum* exact);

}  // namespace lamina
