// Pieces of the renderer's random-walk estimator at a layered surface that need only the stack:
// the reciprocity factor of transmission and the walk's exit density for MIS.
// renderer/surfaces/random_walk_surface.cpp combines them with the light directions the
// integrator draws; `lamina brdf` does not need them.
//
// Reciprocity. The walk with incident direction wo estimates f(wo -> w). The path tracer needs
// f(w -> wo). Reflection is reciprocal: f_r(w -> wo) = f_r(wo -> w). Transmission between media
// of different index is not: f_t(wi -> wo) / n_o^2 = f_t(wo -> wi) / n_i^2 (Veach's thesis,
// eq. 5.19; n of the medium each direction lies in), so with wo above (n_above) and w below
// (n_below), f_t(w -> wo) = f_t(wo -> w) (n_above / n_below)^2: transmission_radiance_factor().
#pragma once

#include <glm/vec3.hpp>

#include "materials/walk/random_walk.h"
#include "materials/stack/stack.h"

namespace lamina {

// (n_above / n_below)^2: multiplies every transmitted contribution (see above). 1 for a stack
// that does not transmit.
double transmission_radiance_factor(const LayerStack& stack);

// The walk's density of leaving straight from `event` along w, as used for MIS between the
// walk's own exits and light samples at events: the mean over the three channels of
// connection_pdf with that channel as the hero. Why not the walk's own hero: the walk's weights
// are already a balance over heroes (spectral MIS), and MIS weights between the exit and the
// light sample are unbiased for any weights that sum to 1 for each path AND do not depend on
// which hero drew it (then the hero average of each technique is the technique's full integral
// times its weight). The hero's own pdf breaks the second condition for coloured media.
// guiding: the walk's WalkOptions::guiding (its exits' density is then the mixture's).
// inside_up: for a rough top interface (single-scattering or energy-conserving), the walk's
// direction in layer 0 at its exit (WalkResult::top_inside), which the pdf depends on
// (prepare_exit_through); ignored if smooth.
double exit_pdf_for_mis(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w, double guiding = 0.0,
                        const glm::dvec3& inside_up = {0.0, 0.0, 1.0});

}  // namespace lamina
