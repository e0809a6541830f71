#include "materials/henyey_greenstein.h"

#include <algorithm>
#include <cmath>

#include "materials/sampling.h"

namespace lamina {

double henyey_greenstein(double cos_theta, double g) {
  const double mu = std::clamp(cos_theta, -1.0, 1.0);
  // 1 + g^2 - 2 g mu written as a sum of non-negative terms:
  //   g >= 0: (1 - g)^2 + 2 g (1 - mu);   g < 0: (1 + g)^2 - 2 g (1 + mu).
  const double base = g >= 0.0 ? (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - mu)
                                : (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + mu);
  return kInv4Pi * (1.0 - g) * (1.0 + g) / (base * std::sqrt(base));
}

double sample_henyey_greenstein_cos(double g, double u) {
  const double xi = 2.0 * u - 1.0;
  const double t = 1.0 + g * xi;
  const double num = xi + 0.5 * g * (3.0 + xi * xi + 2.0 * g * xi + g * g * (xi * xi - 1.0));
  return std::clamp(num / (t * t), -1.0, 1.0);
}

glm::dvec3 rotate_direction(const glm::dvec3& d, double cos_theta, glm::dvec2 azimuth) {
  glm::dvec3 t, b;
  orthonormal_basis(d, &t, &b);
  const double sin_theta = std::sqrt(std::max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
  glm::dvec3 w = sin_theta * azimuth.x * t + sin_theta * azimuth.y * b + cos_theta * d;
  // |w|^2 = 1 + e with e of the order of rounding (d unit, the basis orthonormal): one Newton step
  // of 1/sqrt, 1 - e/2, leaves an error of order e^2 without the square root and the division,
  // which were most of this function's time on the walk's critical path. It also removes a
  // previous step's rounding, so the length cannot drift over a walk's events.
  const double length2 = w.x * w.x + w.y * w.y + w.z * w.z;
  return w * (1.5 - 0.5 * length2);
}

glm::dvec3 sample_henyey_greenstein(const glm::dvec3& d, double g, double u1, double u2) {
  return rotate_direction(d, sample_henyey_greenstein_cos(g, u1), unit_circle(u2));
}

}  // namespace lamina
