#include "materials/sampling.h"

#include <cmath>

namespace lamina {

glm::dvec3 sample_cosine_hemisphere(glm::dvec2 u) {
  const double r = std::sqrt(u.x);
  const glm::dvec2 azimuth = unit_circle(u.y);
  const double z = std::sqrt(std::max(0.0, 1.0 - u.x));
  return {r * azimuth.x, r * azimuth.y, z};
}

glm::dvec3 sample_uniform_sphere(glm::dvec2 u) {
  const double z = 1.0 - 2.0 * u.x;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const glm::dvec2 azimuth = unit_circle(u.y);
  return {r * azimuth.x, r * azimuth.y, z};
}

}  // namespace lamina
