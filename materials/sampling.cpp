#include "materials/sampling.h"

#include <cmath>

namespace lamina {

glm::dvec3 sample_cosine_hemisphere(glm::dvec2 u) {
  const double r = std::sqrt(u.x);
  const double phi = 2.0 * kPi * u.y;
  const double z = std::sqrt(std::max(0.0, 1.0 - u.x));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

glm::dvec3 sample_uniform_sphere(glm::dvec2 u) {
  const double z = 1.0 - 2.0 * u.x;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

void orthonormal_basis(const glm::dvec3& n, glm::dvec3* t, glm::dvec3* b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  *t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  *b = {c, sign + n.y * n.y * a, -n.y};
}

}  // namespace lamina
