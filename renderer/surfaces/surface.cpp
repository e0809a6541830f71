#include "renderer/surfaces/surface.h"

#include <cmath>

#include "materials/base/sampling.h"

namespace lamina {

bool Bsdf::scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count, LightSampler*,
                   SurfaceScatter* next) const {
  for (int k = 0; k < light_count; ++k) {
    LightDirection& l = lights[k];
    l.f_cos = Spectrum(0.0);
    if (is_delta()) continue;
    const Spectrum f = eval(wo, l.wi);
    if (f.is_black()) continue;
    const double mis = l.delta ? 1.0 : power_heuristic(l.pdf, pdf(wo, l.wi));
    l.f_cos = f * (std::abs(l.wi.z) * mis);
  }
  BsdfSample bs;
  if (!sample(wo, glm::dvec2(rng.uniform(), rng.uniform()), &bs)) return false;
  next->wi = bs.wi;
  next->weight = bs.f * (std::abs(bs.wi.z) / bs.pdf);
  next->pdf = bs.pdf;
  next->delta = bs.delta;
  return true;
}

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
