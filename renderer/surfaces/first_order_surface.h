// How the path tracer scatters light at a layered material, per --subsurface mode
// (renderer/layered/shading.h chooses the surface at each hit):
// random-walk: RandomWalkSurface (renderer/surfaces/random_walk_surface.h), a stochastic surface:
//   the top interface's specular reflection is a delta lobe chosen with probability R(wo);
//   otherwise the materials/ random walk runs from the viewer's direction wo and its scattering
//   events connect to the integrator's light directions with connection_weight(); the walk's
//   exits continue the path (the stack-only pieces: materials/walk/walk_estimator.h, which also
//   derives the reciprocity used there).
// first-order: FirstOrderSurface (this file), the analytic zeroth order (delta lobes) and first order.
// table: TableSurface (renderer/surfaces/table_surface.h), a BRDF/BTDF table from the walk
//   (materials/tables/layered_table.h).
// lambert: LambertSurface with LayeredMaterial::lambert_albedo() (materials/tables/albedo.h).
#pragma once

#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"
#include "renderer/surfaces/surface.h"
#include "renderer/surfaces/zeroth_order_lobes.h"

namespace lamina {

// first-order mode: f = zeroth order (delta lobes) + first_order_brdf / first_order_btdf.
// Built per hit for the viewer direction wo (local frame, wo.z > 0; +z the stack's top).
// Sampling: the specular reflection R_specular(wo) and the ballistic transmission
// T_ballistic(wo) as delta lobes with probabilities equal to their mean over channels, else a
// cosine-weighted direction, on both sides with probability 1/2 each for a transmitting stack.
class FirstOrderSurface final : public Bsdf {
 public:
  FirstOrderSurface(const LayerStack& stack, const glm::dvec3& wo);
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  const LayerStack& stack_;
  ZerothOrderLobes lobes_;
};

}  // namespace lamina
