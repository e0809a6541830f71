#include "materials/interfaces/fresnel.h"

#include <algorithm>
#include <cmath>

namespace lamina {

double refracted_cos(double cos_theta_i, double n_i, double n_t) {
  const double cos_i = std::min(1.0, std::abs(cos_theta_i));
  if (n_i == n_t) return cos_i;
  const double eta = n_i / n_t;
  // cos^2(theta_t) = 1 - eta^2 sin^2(theta_i) = (1 - eta)(1 + eta) + eta^2 cos^2(theta_i).
  // The second form has no cancellation at grazing incidence for eta <= 1 (1 - sin^2 would
  // lose ~eps/cos^2 relative precision there) and is as good as the first elsewhere; for
  // eta > 1 the cancellation near the critical angle is the problem's own conditioning.
  // (1 - eta) is exact for eta in [1/2, 2] (Sterbenz).
  const double cos2_t = (1.0 - eta) * (1.0 + eta) + eta * eta * cos_i * cos_i;
  if (cos2_t <= 0.0) return -1.0;  // at or beyond the critical angle
  return std::sqrt(cos2_t);
}

double fresnel_dielectric(double cos_theta_i, double n_i, double n_t) {
  if (n_i == n_t) return 0.0;  // index-matched: no interface at all, even at grazing incidence
  const double cos_i = std::min(1.0, std::abs(cos_theta_i));
  const double cos_t = refracted_cos(cos_i, n_i, n_t);
  if (cos_t < 0.0) return 1.0;  // total internal reflection
  // Fresnel amplitude coefficients for s and p polarisation (Born and Wolf eq. 1.5.20).
  const double r_s = (n_i * cos_i - n_t * cos_t) / (n_i * cos_i + n_t * cos_t);
  const double r_p = (n_t * cos_i - n_i * cos_t) / (n_t * cos_i + n_i * cos_t);
  return std::clamp(0.5 * (r_s * r_s + r_p * r_p), 0.0, 1.0);
}

bool refract_through_plane(glm::dvec3* d, double n_i, double n_t) {
  if (n_i == n_t) return true;  // index-matched: no interface, the direction is kept exactly
  const double cos_t = refracted_cos(d->z, n_i, n_t);
  if (cos_t < 0.0) return false;
  const double eta = n_i / n_t;
  glm::dvec3 out{eta * d->x, eta * d->y, std::copysign(cos_t, d->z)};
  // Renormalise against rounding: |tangential|^2 + cos_t^2 = 1 analytically.
  const double len = std::sqrt(out.x * out.x + out.y * out.y + out.z * out.z);
  *d = out / len;
  return true;
}

}  // namespace lamina
