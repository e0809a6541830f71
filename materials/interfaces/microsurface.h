// An energy-conserving rough dielectric interface: the multiple-scattering microsurface of Heitz,
// Hanika, d'Eon and Dachsbacher, "Multiple-Scattering Microfacet BSDFs with the Smith Model"
// (SIGGRAPH 2016), on the GGX distribution of microfacet.h.
//
// The model. The single-scattering BSDF of microfacet.h (Walter et al. 2007) drops the light
// that meets the microsurface a second time: 10-40 % of it at alpha = 1, and far more in a layer
// that traps light by total internal reflection (docs/materials.md, "Rough interfaces"). Heitz et
// al. treat the Smith microsurface as a volume-like medium in HEIGHT: a ray at height h moving
// along w meets the surface again with the probability Smith's masking gives, at a height drawn
// from it (their section 4, uncorrelated-height model with the uniform height distribution
// C1(h) = (h + 1) / 2 on [-1, 1]); there it picks a visible microfacet (the distribution of
// visible normals of its direction, which may point up or down) and reflects with probability
// F or refracts to the other side (where heights are mirrored: h -> -h). The walk ends when
// the ray leaves upward on either side. Nothing is lost: the interface reflects and transmits
// exactly all the light (weight 1 per sampled path), and the BSDF is reciprocal,
// f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2 (their section 6; tests/materials/interfaces/
// test_microsurface measures both). Its first order is Walter's BSDF with the exact height-
// correlated masking-shadowing: 1 / (1 + Lambda(o) + Lambda(i)) for reflection, the Beta
// function B(1 + Lambda(o), 1 + Lambda(i)) for transmission (Heitz 2014, eq. 101; microfacet.h
// uses 1 / (1 + Lambda + Lambda) for both, as pbrt-v4 does).
//
// Frame and conventions as in microfacet.h: macroscopic normal +z, n_above on the +z side,
// directions point AWAY from the surface, on either side; alpha > 0.
// "Power" densities: P(to | from) is the probability density, per solid angle of `to`, that light
// arriving from direction `from` leaves along `to`; the BSDF for radiance is
// f(wo, wi) = P(wo | wi) / |wo.z|, and the integral of P over all `to` is exactly 1.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/sampling.h"
#include "materials/interfaces/microfacet.h"

namespace lamina {

// Which rough dielectric interface a stack uses (LayerStack::interface_model).
enum class InterfaceModel {
  SingleScattering,  // microfacet.h's RoughDielectric: Walter et al. 2007; loses the light that
                     // scatters twice among the facets (Mitsuba 3's roughdielectric)
  EnergyConserving,  // MicrosurfaceDielectric: Heitz et al. 2016, all orders, no loss
};

struct MicrosurfaceDielectric {
  GgxDistribution distribution;
  double n_above = 1.0;
  double n_below = 1.5;

  // The walks are cut after this many microfacet scatterings (then sample() returns false, the
  // light is lost): a guard, not a model; test Microsurface.WalksLoseNothing sees none of 7e5
  // walks (alpha up to 1, both sides of an index step of 1.5) reach order 64.
  static constexpr int kMaxOrder = 256;

  // One walk on the microsurface of light arriving from `from` (unit, on either side): *to, on
  // the side the light leaves (to.z * from.z > 0: reflected, < 0: transmitted), is distributed
  // with the density P(to | from); the power it carries is exactly the power that arrived
  // (weight 1). *order: the number of microfacet scatterings. False only past kMaxOrder.
  bool sample(const glm::dvec3& from, Rng& rng, glm::dvec3* to, int* order = nullptr) const;

  // The first order of P(to | from) in closed form (the walks of one scattering).
  double density_single(const glm::dvec3& from, const glm::dvec3& to) const;
  // An unbiased estimate of the whole P(to | from): the first order in closed form plus one walk
  // from `from` with next-event estimation towards `to` at each later scattering (the
  // microsurface phase function times the probability of leaving from that height). A few
  // uniforms per scattering; the mean of n estimates has 1/n the variance.
  double density(const glm::dvec3& from, const glm::dvec3& to, Rng& rng) const;

  // The BSDF for radiance f(wo, wi) (1/sr, no cosine): light from wi leaving along wo.
  double eval_single(const glm::dvec3& wo, const glm::dvec3& wi) const;
  double eval(const glm::dvec3& wo, const glm::dvec3& wi, Rng& rng) const;
};

// THE value of a rough interface for callers that tabulate or project it (the adding-doubling
// solver): f(wo, wi), the BSDF for radiance (1/sr, no cosine) of light arriving from wi and
// leaving along wo (both unit, pointing away from the surface; same side: reflection, opposite
// sides: transmission), for GGX alpha > 0, the indices above (+z) and below (-z), and the model.
// SingleScattering: RoughDielectric::eval, exact and deterministic. EnergyConserving: the mean of
// `samples` unbiased estimates (MicrosurfaceDielectric::eval, seeded from `seed` and the
// directions, so the same call gives the same value); its first order is exact, the rest has a
// relative standard error that falls as 1/sqrt(samples). Reciprocal in both models:
// f(wo, wi) / n(wo)^2 = f(wi, wo) / n(wi)^2.
double rough_interface_bsdf(InterfaceModel model, double alpha, double n_above, double n_below,
                            const glm::dvec3& wo, const glm::dvec3& wi, int samples = 64,
                            std::uint64_t seed = 1);

}  // namespace lamina
