#include "renderer/surfaces/metallic_roughness_surface.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "materials/base/sampling.h"

namespace lamina {

namespace {
constexpr double kDielectricF0 = 0.04;  // glTF Appendix B: ior 1.5

double schlick_weight(double cos_theta) {
  const double x = 1.0 - std::clamp(std::abs(cos_theta), 0.0, 1.0);
  const double x2 = x * x;
  return x2 * x2 * x;
}

double luminance(const Spectrum& s) { return 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]; }
}  // namespace

MetallicRoughnessSurface::MetallicRoughnessSurface(const Spectrum& base_color, double metallic, double roughness)
    : base_(base_color), metallic_(std::clamp(metallic, 0.0, 1.0)) {
  const double r = std::clamp(roughness, 0.0, 1.0);
  distribution_.alpha = std::max(r * r, 1e-3);
}

Spectrum MetallicRoughnessSurface::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (!(wo.z > 0.0) || !(wi.z > 0.0)) return Spectrum(0.0);
  glm::dvec3 h;
  if (!reflection_half_vector(wo, wi, &h)) return Spectrum(0.0);
  const double voh = glm::dot(wo, h);
  if (!(voh > 0.0)) return Spectrum(0.0);
  const double s = distribution_.d(h) * distribution_.g2(wo, wi) / (4.0 * wo.z * wi.z);
  const double w = schlick_weight(voh);
  const double f_d = kDielectricF0 + (1.0 - kDielectricF0) * w;
  const Spectrum f_m = base_ + (Spectrum(1.0) - base_) * w;
  const Spectrum dielectric = base_ * ((1.0 - f_d) * kInvPi) + Spectrum(f_d * s);
  return dielectric * (1.0 - metallic_) + f_m * (s * metallic_);
}

// The specular lobe's expected share at wo, with the Fresnel terms at the macro normal: the
// specular weight (1 - m) F_d + m lum(F_m) against the diffuse (1 - m)(1 - F_d) lum(base).
// Clamped to [0.1, 0.9] when both lobes exist, so neither is starved; 1 for a pure metal or a
// black base.
double MetallicRoughnessSurface::specular_probability(const glm::dvec3& wo) const {
  const double w = schlick_weight(wo.z);
  const double f_d = kDielectricF0 + (1.0 - kDielectricF0) * w;
  const double spec = (1.0 - metallic_) * f_d + metallic_ * luminance(base_ + (Spectrum(1.0) - base_) * w);
  const double diffuse = (1.0 - metallic_) * (1.0 - f_d) * luminance(base_);
  if (!(diffuse > 0.0)) return 1.0;
  return std::clamp(spec / (spec + diffuse), 0.1, 0.9);
}

bool MetallicRoughnessSurface::sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const {
  if (!(wo.z > 0.0)) return false;
  const double p_spec = specular_probability(wo);
  glm::dvec3 wi;
  // u.x chooses the lobe and is stretched back to [0, 1) for it.
  if (u.x < p_spec) {
    const glm::dvec3 h = distribution_.sample_visible(wo, {u.x / p_spec, u.y});
    wi = 2.0 * glm::dot(wo, h) * h - wo;
  } else {
    wi = sample_cosine_hemisphere({(u.x - p_spec) / (1.0 - p_spec), u.y});
  }
  if (!(wi.z > 0.0)) return false;
  return complete_sample(*this, wo, wi, s);
}

double MetallicRoughnessSurface::pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (!(wo.z > 0.0) || !(wi.z > 0.0)) return 0.0;
  const double p_spec = specular_probability(wo);
  return p_spec * reflection_pdf(distribution_, wo, wi) + (1.0 - p_spec) * wi.z * kInvPi;
}

}  // namespace lamina
