// The local shading frame of a hit: +z the shading normal (docs/contracts.md, "Conventions").
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "materials/base/sampling.h"

namespace lamina {

// Local shading frame around n: to_local(v) = (v.t, v.b, v.n).
struct Frame {
  glm::dvec3 t{0.0}, b{0.0}, n{0.0, 0.0, 1.0};
  Frame() = default;
  explicit Frame(const glm::dvec3& normal) : n(normal) { orthonormal_basis(n, &t, &b); }
  glm::dvec3 to_local(const glm::dvec3& v) const { return {glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)}; }
  glm::dvec3 to_world(const glm::dvec3& v) const { return v.x * t + v.y * b + v.z * n; }
};

}  // namespace lamina
