#include "renderer/surfaces/surface.h"

#include "materials/sampling.h"

namespace lamina {

Spectrum LambertSurface::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  return (wo.z > 0.0 && wi.z > 0.0) ? albedo_ * kInvPi : Spectrum(0.0);
}

bool LambertSurface::sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const {
  if (wo.z <= 0.0) return false;
  s->wi = sample_cosine_hemisphere(u);
  s->pdf = s->wi.z * kInvPi;
  if (!(s->pdf > 0.0)) return false;  // u on the rim: wi.z = 0 carries no light
  s->f = albedo_ * kInvPi;
  s->delta = false;
  return true;
}

double LambertSurface::pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  return (wo.z > 0.0 && wi.z > 0.0) ? wi.z * kInvPi : 0.0;
}

}  // namespace lamina
