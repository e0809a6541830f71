// glTF 2.0's metallic-roughness material (glTF 2.0 specification, Appendix B "BRDF
// Implementation"): a mix, by metalness, of a metal (GGX specular with Schlick's Fresnel of
// F0 = base colour) and a dielectric (GGX specular of F0 = 0.04 over a Lambert base, combined by
// the Fresnel mix: f = (1 - F) diffuse + F specular):
//   f = (1 - metallic) [ (1 - F_d) base / pi + F_d S ] + metallic F_m S,
//   S = D(h) G2(wo, wi) / (4 |wo.z| |wi.z|) (materials/interfaces/microfacet.h), alpha = roughness^2,
//   F_d = 0.04 + 0.96 (1 - |wo.h|)^5,  F_m = base + (1 - base) (1 - |wo.h|)^5.
// Reflection only (the upper hemisphere). As specified it is not energy conserving at grazing
// views (the diffuse keeps 1 - F(wo.h) of a half vector that is near the normal for most wi):
// a white base at 80 degrees reflects up to 1.35; kept as glTF specifies (what other glTF
// renderers show). Sampling: the specular lobe by visible normals with a
// probability that follows its expected share at wo, else the cosine; pdf() is the mixture.
#pragma once

#include "materials/interfaces/microfacet.h"
#include "renderer/surfaces/surface.h"

namespace lamina {

class MetallicRoughnessSurface final : public Bsdf {
 public:
  // roughness is glTF's perceptual roughness in [0, 1]; alpha = roughness^2, at least 1e-3 (a
  // smaller lobe would be a mirror that no light sample can reach).
  MetallicRoughnessSurface(const Spectrum& base_color, double metallic, double roughness);

  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

  double alpha() const { return distribution_.alpha; }
  // The probability of sampling the specular lobe from wo.
  double specular_probability(const glm::dvec3& wo) const;

 private:
  Spectrum base_;
  double metallic_;
  GgxDistribution distribution_;
};

}  // namespace lamina
