// Rough interfaces: the GGX (Trowbridge-Reitz) microfacet model with height-correlated Smith
// masking-shadowing, visible-normal sampling, and the rough dielectric and rough conductor
// BSDFs built on it.
//
// Sources: Walter, Marschner, Li and Torrance, "Microfacet Models for Refraction through Rough
// Surfaces" (EGSR 2007): the distribution D (their eq. 33), the BSDFs (eqs. 20, 21) and the
// half-vector Jacobians (eqs. 14, 17); Heitz, "Understanding the Masking-Shadowing Function in
// Microfacet-Based BRDFs" (JCGT 2014): Lambda of GGX (eq. 86) and the height-correlated G2
// (eq. 99); Heitz, "Sampling the GGX Distribution of Visible Normals" (JCGT 2018): the sampler
// and its density D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z (eq. 3). pbrt-v4 section 9.6-9.7
// uses the same formulas (and the same G2 for transmission).
//
// Frame: the macroscopic normal is +z. Directions point AWAY from the surface (wo towards the
// viewer, wi towards the light), on either side. alpha is GGX's roughness (0 < alpha; the smooth
// limit alpha -> 0 is the caller's delta lobe: these functions are not defined at alpha = 0).
// A single-scattering model: light that would scatter twice among the microfacets is lost, so
// the albedo at alpha = 1 is below 1 (tests/materials/interfaces/test_microfacet measures it).
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"

namespace lamina {

struct GgxDistribution {
  double alpha = 0.5;

  // Microfacet normal density D(m), normalised so that integral D(m) m.z d(omega_m) = 1 over the
  // upper hemisphere. Zero for m.z <= 0.
  double d(const glm::dvec3& m) const;
  // Smith's Lambda(w) = (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2; symmetric in the sign of w.z.
  double lambda(const glm::dvec3& w) const;
  // Masking G1(w) = 1 / (1 + Lambda(w)).
  double g1(const glm::dvec3& w) const { return 1.0 / (1.0 + lambda(w)); }
  // Height-correlated masking-shadowing G2(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)).
  double g2(const glm::dvec3& wo, const glm::dvec3& wi) const { return 1.0 / (1.0 + lambda(wo) + lambda(wi)); }
  // Visible-normal density D_wo(m) = G1(wo) max(0, wo.m) D(m) / |wo.z| of the normals seen from
  // wo (wo on either side: taken on its own side, i.e. m is flipped with it).
  double visible_pdf(const glm::dvec3& wo, const glm::dvec3& m) const;
  // Samples m ~ D_wo (Heitz 2018, listing 1), on wo's side of the surface (m.z has wo.z's sign).
  glm::dvec3 sample_visible(const glm::dvec3& wo, glm::dvec2 u) const;
};

// The microfacet normal of a reflection pair: normalize(wo + wi), turned to +z. False if wo and
// wi are not on the same side or wo + wi is zero.
bool reflection_half_vector(const glm::dvec3& wo, const glm::dvec3& wi, glm::dvec3* m);
// The generalised half vector of a refraction pair (Walter eq. 16): -(n_o wo + n_i wi) normalised,
// turned to +z, where n_o, n_i are the indices of the media wo and wi lie in. False if the pair
// is not on opposite sides, or either direction is on the wrong side of m (no microfacet
// refracts one into the other).
bool refraction_half_vector(const glm::dvec3& wo, double n_o, const glm::dvec3& wi, double n_i, glm::dvec3* m);
// Refraction of the direction w (pointing away from the surface on its side, index n_from) through
// a microfacet of normal m (on w's side) into the medium of index n_to: the transmitted direction
// (pointing away from the surface on the other side). False under total internal reflection.
bool refract_about(const glm::dvec3& w, const glm::dvec3& m, double n_from, double n_to, glm::dvec3* t);

// A rough dielectric interface between the index n_above (+z side) and n_below (-z side).
// f is the BSDF for radiance (Walter eq. 21, with its (n_o / (n_i i.m + n_o o.m))^2: the
// radiance of transmitted light scales with n^2): it obeys f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2,
// n_o the index on wo's side (Veach's thesis eq. 5.28).
struct RoughDielectric {
  GgxDistribution distribution;
  double n_above = 1.0;
  double n_below = 1.5;

  double index_of(const glm::dvec3& w) const { return w.z > 0.0 ? n_above : n_below; }
  // f(wo, wi) (1/sr, no cosine), reflection or transmission by the sides of wo and wi.
  double eval(const glm::dvec3& wo, const glm::dvec3& wi) const;
  // Density (per solid angle of wi) of sample() from wo.
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const;
  // The density of wi (on the far side of wo) for a sampler that always refracts: m ~ D_wo, then
  // refraction; pdf() of a refraction is (1 - F(wo.m)) times this.
  double refraction_pdf(const glm::dvec3& wo, const glm::dvec3& wi) const;
  struct Sample {
    glm::dvec3 wi{0.0, 0.0, 1.0};
    double weight = 0.0;  // f |wi.z| / pdf (0: the sample left the surface on the wrong side)
    double pdf = 0.0;
    bool reflected = false;
  };
  // m ~ D_wo (u), then reflection with probability F(wo.m), else refraction (u_choice). The
  // weight f |wi.z| / pdf is G2/G1(wo) for a reflection and G2/G1(wo) (n_o/n_i)^2 for a
  // refraction (the n^2 law of radiance). With `power`, a refraction's weight is G2/G1(wo):
  // what a packet of POWER keeps, as the random walk inside a stack carries
  // (materials/walk/random_walk.h; by reciprocity, the n^2 factor is applied where the walk's
  // estimate becomes radiance).
  Sample sample(const glm::dvec3& wo, glm::dvec2 u, double u_choice, bool power = false) const;

  // The two lobes sampled alone, from a facet m ~ D_wo (u), for callers that split the interface
  // themselves (the layered walk and its surface: the reflection is the surface's glossy lobe,
  // the refraction the walk's way in).
  // Reflection: wi = reflect(wo, m) and its weight f_r |wi.z| / pdf_r = F(wo.m) G2/G1(wo); false
  // (wi and weight unset) if wi lies below the facets.
  bool sample_reflection(const glm::dvec3& wo, glm::dvec2 u, glm::dvec3* wi, double* weight) const;
  // Refraction: wi through m, the facet's Fresnel reflectance F(wo.m) (1 if wo cannot see m) and
  // the masking ratio G2/G1(wo); the power carried is (1 - F) G2/G1. False (fresnel still set)
  // under total internal reflection or if wi does not reach the far side.
  bool sample_refraction(const glm::dvec3& wo, glm::dvec2 u, glm::dvec3* wi, double* fresnel, double* masking) const;
};

// Fresnel reflectance of a conductor of complex index eta + i k (relative to the outside medium)
// for unpolarised light (pbrt-v4 9.3.6, FrComplex), per channel.
Spectrum fresnel_conductor(double cos_theta_i, const Spectrum& eta, const Spectrum& k);
// Schlick's approximation F0 + (1 - F0) (1 - cos)^5 (glTF 2.0 Appendix B).
Spectrum fresnel_schlick(double cos_theta, const Spectrum& f0);

// A rough conductor: f = D G2 F / (4 |wo.z| |wi.z|) on the upper side, with the caller's Fresnel.
struct RoughConductor {
  GgxDistribution distribution;
  Spectrum eta{0.2};
  Spectrum k{3.9};

  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const;
  // wi from the visible normals of wo, reflected; false if it leaves below the surface.
  bool sample(const glm::dvec3& wo, glm::dvec2 u, glm::dvec3* wi) const;
};

// The density of microfacet reflection sampling (visible normals of wo, then reflect) at wi:
// D_wo(m) / (4 |wo.m|) (Walter eq. 14 for the Jacobian). 0 if wi is not on wo's side.
double reflection_pdf(const GgxDistribution& distribution, const glm::dvec3& wo, const glm::dvec3& wi);

}  // namespace lamina
