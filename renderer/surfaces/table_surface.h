// table mode: the layered surface as a tabulated BRDF/BTDF (materials/layered_table.h: layout,
// interpolation and sampling) plus the exact zeroth order's delta lobes.
#pragma once

#include <glm/vec3.hpp>

#include "materials/layered_table.h"
#include "materials/spectrum.h"
#include "renderer/surfaces/surface.h"
#include "renderer/surfaces/zeroth_order_lobes.h"

namespace lamina {

class TableSurface final : public Surface {
 public:
  TableSurface(const LayeredTable& table, const glm::dvec3& wo);
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  int bin_of(const glm::dvec3& wo, const glm::dvec3& wi) const;
  const LayeredTable& table_;
  ZerothOrderLobes lobes_;
  int node_[2] = {0, 0};
  double weight_[2] = {1.0, 0.0};
};

}  // namespace lamina
