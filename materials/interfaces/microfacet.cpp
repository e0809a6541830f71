#include "materials/interfaces/microfacet.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include <glm/geometric.hpp>

#include "materials/interfaces/fresnel.h"
#include "materials/base/sampling.h"

namespace lamina {

// D(m) = alpha^2 / (pi cos^4 theta_m (alpha^2 + tan^2 theta_m)^2) (Walter eq. 33), written with
// cos^2 only: cos^4 (alpha^2 + tan^2)^2 = (cos^2 (alpha^2 - 1) + 1)^2.
double GgxDistribution::d(const glm::dvec3& m) const {
  if (!(m.z > 0.0)) return 0.0;
  const double a2 = alpha * alpha;
  const double c2 = m.z * m.z;
  const double denom = c2 * (a2 - 1.0) + 1.0;
  return a2 / (kPi * denom * denom);
}

// Lambda(w) = (-1 + sqrt(1 + alpha^2 tan^2 theta)) / 2 (Heitz 2014 eq. 86); tan^2 = sin^2 / cos^2.
double GgxDistribution::lambda(const glm::dvec3& w) const {
  const double c2 = w.z * w.z;
  if (c2 == 0.0) return std::numeric_limits<double>::infinity();
  const double s2 = std::max(0.0, w.x * w.x + w.y * w.y);
  const double a2_tan2 = alpha * alpha * s2 / c2;
  // (sqrt(1 + x) - 1) / 2 = x / (2 (sqrt(1 + x) + 1)): no cancellation for small x.
  return a2_tan2 / (2.0 * (std::sqrt(1.0 + a2_tan2) + 1.0));
}

double GgxDistribution::visible_pdf(const glm::dvec3& wo_in, const glm::dvec3& m_in) const {
  glm::dvec3 wo = wo_in, m = m_in;
  if (wo.z < 0.0) {
    wo = -wo;
    m = -m;
  }
  if (!(wo.z > 0.0)) return 0.0;
  const double cos_om = glm::dot(wo, m);
  if (!(cos_om > 0.0)) return 0.0;
  return g1(wo) * cos_om * d(m) / wo.z;
}

// Heitz 2018, listing 1: stretch wo to the configuration of alpha = 1, sample the projected
// disk of the hemisphere it sees (a disk whose far half is squashed by (1 + wo.z) / 2), lift the
// point to the hemisphere and unstretch the normal.
glm::dvec3 GgxDistribution::sample_visible(const glm::dvec3& wo_in, glm::dvec2 u) const {
  const bool flip = wo_in.z < 0.0;
  const glm::dvec3 wo = flip ? -wo_in : wo_in;
  const glm::dvec3 vh = glm::normalize(glm::dvec3(alpha * wo.x, alpha * wo.y, wo.z));
  const double len2 = vh.x * vh.x + vh.y * vh.y;
  const glm::dvec3 t1 = len2 > 0.0 ? glm::dvec3(-vh.y, vh.x, 0.0) / std::sqrt(len2) : glm::dvec3(1.0, 0.0, 0.0);
  const glm::dvec3 t2 = glm::cross(vh, t1);
  const double r = std::sqrt(u.x);
  const double phi = 2.0 * kPi * u.y;
  const double p1 = r * std::cos(phi);
  double p2 = r * std::sin(phi);
  const double s = 0.5 * (1.0 + vh.z);
  p2 = (1.0 - s) * std::sqrt(std::max(0.0, 1.0 - p1 * p1)) + s * p2;
  const glm::dvec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
  glm::dvec3 m = glm::normalize(glm::dvec3(alpha * nh.x, alpha * nh.y, std::max(1e-300, nh.z)));
  return flip ? -m : m;
}

bool reflection_half_vector(const glm::dvec3& wo, const glm::dvec3& wi, glm::dvec3* m) {
  if (!(wo.z * wi.z > 0.0)) return false;
  const glm::dvec3 h = wo + wi;
  const double len = glm::length(h);
  if (!(len > 0.0)) return false;
  *m = h.z < 0.0 ? -h / len : h / len;
  return true;
}

bool refraction_half_vector(const glm::dvec3& wo, double n_o, const glm::dvec3& wi, double n_i, glm::dvec3* m) {
  if (!(wo.z * wi.z < 0.0)) return false;
  const glm::dvec3 h = -(n_o * wo + n_i * wi);
  const double len = glm::length(h);
  if (!(len > 0.0)) return false;
  glm::dvec3 n = h / len;
  if (n.z < 0.0) n = -n;
  // Both directions must lie on their own side of the microfacet.
  if (!(glm::dot(n, wo) * wo.z > 0.0) || !(glm::dot(n, wi) * wi.z > 0.0)) return false;
  *m = n;
  return true;
}

bool refract_about(const glm::dvec3& w, const glm::dvec3& m, double n_from, double n_to, glm::dvec3* t) {
  const double eta = n_from / n_to;
  const double cos_i = glm::dot(w, m);
  const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_i * cos_i);
  if (sin2_t >= 1.0) return false;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  *t = glm::normalize(-eta * w + (eta * cos_i - cos_t) * m);
  return true;
}

double RoughDielectric::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z == 0.0 || wi.z == 0.0) return 0.0;
  const double n_o = index_of(wo);
  const double n_far = wo.z > 0.0 ? n_below : n_above;
  const GgxDistribution& dist = distribution;
  glm::dvec3 m;
  if (wo.z * wi.z > 0.0) {
    // Reflection (Walter eq. 20): D G F / (4 |wo.z| |wi.z|).
    if (!reflection_half_vector(wo, wi, &m)) return 0.0;
    if (!(glm::dot(m, wo) * wo.z > 0.0) || !(glm::dot(m, wi) * wi.z > 0.0)) return 0.0;
    const double f = fresnel_dielectric(glm::dot(wo, m), n_o, n_far);
    return dist.d(m) * dist.g2(wo, wi) * f / (4.0 * std::abs(wo.z) * std::abs(wi.z));
  }
  // Refraction (Walter eq. 21).
  const double n_i = index_of(wi);
  if (n_i == n_o) return 0.0;  // index matched: no microfacet refracts (a delta transmission)
  if (!refraction_half_vector(wo, n_o, wi, n_i, &m)) return 0.0;
  const double om = glm::dot(wo, m), im = glm::dot(wi, m);
  const double f = fresnel_dielectric(om, n_o, n_i);
  const double denom = n_i * im + n_o * om;
  return std::abs(im) * std::abs(om) / (std::abs(wi.z) * std::abs(wo.z)) * n_o * n_o * (1.0 - f) *
         dist.g2(wo, wi) * dist.d(m) / (denom * denom);
}

double RoughDielectric::pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z == 0.0 || wi.z == 0.0) return 0.0;
  const double n_o = index_of(wo);
  const double n_far = wo.z > 0.0 ? n_below : n_above;
  glm::dvec3 m;
  if (wo.z * wi.z > 0.0) {
    if (!reflection_half_vector(wo, wi, &m)) return 0.0;
    if (!(glm::dot(m, wo) * wo.z > 0.0) || !(glm::dot(m, wi) * wi.z > 0.0)) return 0.0;
    const glm::dvec3 m_wo = wo.z > 0.0 ? m : -m;
    const double om = std::abs(glm::dot(wo, m));
    const double f = fresnel_dielectric(om, n_o, n_far);
    return f * distribution.visible_pdf(wo, m_wo) / (4.0 * om);
  }
  const double n_i = index_of(wi);
  if (n_i == n_o) return 0.0;
  if (!refraction_half_vector(wo, n_o, wi, n_i, &m)) return 0.0;
  return (1.0 - fresnel_dielectric(glm::dot(wo, m), n_o, n_i)) * refraction_pdf(wo, wi);
}

double RoughDielectric::refraction_pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (!(wo.z * wi.z < 0.0)) return 0.0;
  const double n_o = index_of(wo), n_i = index_of(wi);
  if (n_i == n_o) return 0.0;
  glm::dvec3 m;
  if (!refraction_half_vector(wo, n_o, wi, n_i, &m)) return 0.0;
  const glm::dvec3 m_wo = wo.z > 0.0 ? m : -m;
  const double om = glm::dot(wo, m), im = glm::dot(wi, m);
  const double denom = n_i * im + n_o * om;
  // d(omega_m)/d(omega_i) = n_i^2 |wi.m| / (n_i wi.m + n_o wo.m)^2 (Walter eq. 17).
  return distribution.visible_pdf(wo, m_wo) * n_i * n_i * std::abs(im) / (denom * denom);
}

RoughDielectric::Sample RoughDielectric::sample(const glm::dvec3& wo, glm::dvec2 u, double u_choice,
                                                bool power) const {
  Sample s;
  if (wo.z == 0.0) return s;
  const double n_o = index_of(wo);
  const double n_far = wo.z > 0.0 ? n_below : n_above;
  const glm::dvec3 m = distribution.sample_visible(wo, u);  // on wo's side
  const double om = glm::dot(wo, m);
  if (!(om > 0.0)) return s;
  const double f = fresnel_dielectric(om, n_o, n_far);
  glm::dvec3 wi;
  if (u_choice < f || n_o == n_far) {
    if (n_o == n_far) {
      // Index matched: light passes straight through (F = 0); not a microfacet event.
      s.wi = -wo;
      s.weight = 1.0;
      s.pdf = 0.0;
      return s;
    }
    wi = 2.0 * om * m - wo;
    s.reflected = true;
    if (!(wi.z * wo.z > 0.0)) return s;  // below the surface: lost (single scattering)
  } else {
    if (!refract_about(wo, m, n_o, n_far, &wi)) return s;  // unreachable: F = 1 under TIR
    if (!(wi.z * wo.z < 0.0)) return s;
  }
  s.wi = wi;
  s.pdf = pdf(wo, wi);
  if (!(s.pdf > 0.0)) return s;
  const double ratio = distribution.g2(wo, wi) / distribution.g1(wo);  // G2 / G1(wo)
  s.weight = s.reflected || power ? ratio : ratio * (n_o * n_o) / (n_far * n_far);
  return s;
}

bool RoughDielectric::sample_reflection(const glm::dvec3& wo, glm::dvec2 u, glm::dvec3* wi, double* weight) const {
  const glm::dvec3 m = distribution.sample_visible(wo, u);
  const double cos_m = glm::dot(wo, m);
  const glm::dvec3 r = 2.0 * cos_m * m - wo;
  if (!(cos_m > 0.0) || !(r.z * wo.z > 0.0)) return false;  // below the facets: the model's loss
  const double f = fresnel_dielectric(cos_m, index_of(wo), wo.z > 0.0 ? n_below : n_above);
  *wi = r;
  *weight = f * distribution.g2(wo, r) / distribution.g1(wo);
  return true;
}

bool RoughDielectric::sample_refraction(const glm::dvec3& wo, glm::dvec2 u, glm::dvec3* wi, double* fresnel,
                                        double* masking) const {
  const double n_o = index_of(wo), n_far = wo.z > 0.0 ? n_below : n_above;
  const glm::dvec3 m = distribution.sample_visible(wo, u);
  const double cos_m = glm::dot(wo, m);
  *fresnel = cos_m > 0.0 ? fresnel_dielectric(cos_m, n_o, n_far) : 1.0;
  glm::dvec3 t;
  if (!(cos_m > 0.0) || !refract_about(wo, m, n_o, n_far, &t) || !(t.z * wo.z < 0.0)) return false;
  *wi = t;
  *masking = distribution.g2(wo, t) / distribution.g1(wo);
  return true;
}

Spectrum fresnel_conductor(double cos_theta_i, const Spectrum& eta, const Spectrum& k) {
  Spectrum out;
  const double c = std::clamp(std::abs(cos_theta_i), 0.0, 1.0);
  for (int ch = 0; ch < kChannels; ++ch) {
    const std::complex<double> n(eta[ch], k[ch]);
    const std::complex<double> sin2_t = (1.0 - c * c) / (n * n);
    const std::complex<double> cos_t = std::sqrt(1.0 - sin2_t);
    const std::complex<double> r_parallel = (n * c - cos_t) / (n * c + cos_t);
    const std::complex<double> r_perpendicular = (c - n * cos_t) / (c + n * cos_t);
    out[ch] = 0.5 * (std::norm(r_parallel) + std::norm(r_perpendicular));
  }
  return out;
}

Spectrum fresnel_schlick(double cos_theta, const Spectrum& f0) {
  const double x = 1.0 - std::clamp(std::abs(cos_theta), 0.0, 1.0);
  const double x2 = x * x;
  return f0 + (Spectrum(1.0) - f0) * (x2 * x2 * x);
}

double reflection_pdf(const GgxDistribution& distribution, const glm::dvec3& wo, const glm::dvec3& wi) {
  glm::dvec3 m;
  if (!reflection_half_vector(wo, wi, &m)) return 0.0;
  const glm::dvec3 m_wo = wo.z > 0.0 ? m : -m;
  const double om = glm::dot(wo, m_wo);
  if (!(om > 0.0)) return 0.0;
  return distribution.visible_pdf(wo, m_wo) / (4.0 * om);
}

Spectrum RoughConductor::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (!(wo.z > 0.0) || !(wi.z > 0.0)) return Spectrum(0.0);
  glm::dvec3 m;
  if (!reflection_half_vector(wo, wi, &m)) return Spectrum(0.0);
  const double om = glm::dot(wo, m);
  if (!(om > 0.0) || !(glm::dot(wi, m) > 0.0)) return Spectrum(0.0);
  return fresnel_conductor(om, eta, k) * (distribution.d(m) * distribution.g2(wo, wi) / (4.0 * wo.z * wi.z));
}

double RoughConductor::pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (!(wo.z > 0.0) || !(wi.z > 0.0)) return 0.0;
  return reflection_pdf(distribution, wo, wi);
}

bool RoughConductor::sample(const glm::dvec3& wo, glm::dvec2 u, glm::dvec3* wi) const {
  if (!(wo.z > 0.0)) return false;
  const glm::dvec3 m = distribution.sample_visible(wo, u);
  *wi = 2.0 * glm::dot(wo, m) * m - wo;
  return wi->z > 0.0;
}

}  // namespace lamina
