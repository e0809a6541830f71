// The narrow interface through which the integrator scatters light at a surface.
//
// Directions are in the local shading frame: +z is the shading normal turned to the side of
// wo (the viewer), wi points towards the light (docs/contracts.md, "Conventions").
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/sampling.h"
#include "materials/base/spectrum.h"

namespace lamina {

struct BsdfSample {
  Spectrum f;
  glm::dvec3 wi{0.0, 0.0, 1.0};
  double pdf = 0.0;
  bool delta = false;  // a Dirac lobe: f and pdf are both "per delta", MIS does not apply
};

// A direction towards a light sample that the integrator drew at the shading point (next-event
// estimation), offered to the surface to connect to.
struct LightDirection {
  glm::dvec3 wi{0.0, 0.0, 1.0};  // local frame, towards the light
  // Solid-angle density of the light sample including the light's selection probability, for
  // MIS against the surface's own sampling; ignored for a delta light.
  double pdf = 0.0;
  bool delta = false;
  // Filled by Surface::scatter: an unbiased estimate of f(wo, wi) |cos theta_i| times the MIS
  // weight of the light sample against the surface's own sampling (1 for a delta light).
  Spectrum f_cos;
};

// Fresh light samples for a stochastic surface that connects to the lights from many internal
// events (the layered walk) and is better served by an independent sample per event than by one
// shared direction: an environment or area light seen through a weakly forward-scattering
// medium, where the events of one walk would otherwise all see the same point of the light.
// The integrator implements it; each add() belongs to the direction of the draw() before it.
class LightSampler {
 public:
  virtual ~LightSampler() = default;
  // Draws a light sample at the shading point (local frame); false if there is none.
  virtual bool draw(Rng& rng, LightDirection* light) = 0;
  // Adds f_cos (the surface's MIS-weighted f |cos| estimate towards the last drawn direction)
  // if the light is visible along it.
  virtual void add(const Spectrum& f_cos) = 0;
};

// How the path continues after a scattering event.
struct SurfaceScatter {
  glm::dvec3 wi{0.0, 0.0, 1.0};
  Spectrum weight;  // estimate of f |cos| / pdf: the path throughput's factor
  // MIS: if the continuation finds an emitter, its weight is the power heuristic of pdf
  // against the light sampling density; delta: light sampling could not have found it (weight 1).
  double pdf = 0.0;
  bool delta = false;
};

// What the integrator calls at a hit (renderer/layered/shading.h builds it): one scattering
// event, whatever the surface is. Two kinds implement it: Bsdf (below), a BSDF that can be
// evaluated and sampled, and the stochastic surfaces that can only be estimated (the layered
// random walk, renderer/surfaces/random_walk_surface.h).
class Surface {
 public:
  virtual ~Surface() = default;
  // True if every lobe is a delta (light sampling is then useless).
  virtual bool is_delta() const { return false; }

  // One scattering event as the integrator sees it: fill lights[k].f_cos for every light
  // direction offered, and choose how the path continues (false: it ends here; the light
  // connections still count). A Bsdf does it the classic way (Bsdf::scatter); a stochastic
  // surface estimates the connections and the continuation from one run of its own sampling.
  // per_event: null, or a sampler to draw additional light samples from (only surfaces whose
  // draws_per_event() is true use it; the integrator then leaves those lights out of `lights`).
  virtual bool scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count,
                       LightSampler* per_event, SurfaceScatter* next) const = 0;
  // True if this surface connects from internal events and wants a LightSampler for the lights
  // it is better to sample per event (see LightSampler).
  virtual bool draws_per_event() const { return false; }
};

// A surface with a BSDF that can be evaluated: eval() returns f(wo, wi) in 1/sr without the
// cosine; sample() draws wi with solid-angle density pdf and returns f(wo, wi).
class Bsdf : public Surface {
 public:
  virtual Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const = 0;
  virtual bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const = 0;
  virtual double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const = 0;

  // The classic event of a BSDF that can be evaluated: f_cos = eval |cos| times the power
  // heuristic against pdf(), then sample() with two uniforms.
  bool scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count, LightSampler* per_event,
               SurfaceScatter* next) const override;
};

// Power heuristic with beta = 2 (Veach 1997, eq. 9.13), for one sample of each strategy.
inline double power_heuristic(double pdf_a, double pdf_b) {
  const double a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return a + b > 0.0 ? a / (a + b) : 0.0;
}

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
class LambertSurface final : public Bsdf {
 public:
  explicit LambertSurface(const Spectrum& albedo) : albedo_(albedo) {}
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  Spectrum albedo_;
};

}  // namespace lamina
