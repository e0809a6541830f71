// The narrow interface through which the integrator scatters light at a surface.
//
// Directions are in the local shading frame: +z is the shading normal turned to the side of
// wo (the viewer), wi points towards the light (docs/contracts.md, "Conventions"). eval() returns
// the BSDF f(wo, wi) in 1/sr without the cosine; sample() draws wi with solid-angle density
// pdf and returns f(wo, wi).
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/spectrum.h"

namespace lamina {

struct BsdfSample {
  Spectrum f;
  glm::dvec3 wi{0.0, 0.0, 1.0};
  double pdf = 0.0;
  bool delta = false;  // a Dirac lobe: f and pdf are both "per delta", MIS does not apply
};

class Surface {
 public:
  virtual ~Surface() = default;
  virtual Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const = 0;
  virtual bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const = 0;
  virtual double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const = 0;
  // True if every lobe is a delta (light sampling is then useless).
  virtual bool is_delta() const { return false; }
  // Layered (Hanrahan-Krueger) materials take over the whole scattering event with their random
  // walk, connecting to lights at each internal event; the integrator asks here and hands the
  // event over. No surface is layered yet (the layered-materials issue adds one).
  virtual bool is_layered() const { return false; }
};

// Completes the sample of a non-delta lobe that drew the direction wi: f and pdf come from the
// surface's own eval and pdf, so sample() agrees with them exactly. False for a grazing wi
// (wi.z == 0) or a zero pdf. A template so that a final surface's calls stay direct.
template <class SurfaceT>
bool complete_sample(const SurfaceT& surface, const glm::dvec3& wo, const glm::dvec3& wi, BsdfSample* s) {
  if (wi.z == 0.0) return false;
  s->wi = wi;
  s->pdf = surface.pdf(wo, wi);
  s->f = surface.eval(wo, wi);
  s->delta = false;
  return s->pdf > 0.0;
}

// Lambert: f = albedo / pi on the reflection side, sampled by the cosine (pbrt-v4 9.2).
class LambertSurface final : public Surface {
 public:
  explicit LambertSurface(const Spectrum& albedo) : albedo_(albedo) {}
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  Spectrum albedo_;
};

}  // namespace lamina
