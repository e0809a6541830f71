#include "renderer/scene/alpha_coverage.h"

#include <algorithm>

#include <cstring>

#include <glm/vec2.hpp>

#include "materials/base/sampling.h"

namespace lamina {

double coverage_alpha(const AlphaCoverage& c, std::uint32_t triangle, double b1, double b2) {
  const Mesh& m = *c.mesh;
  double alpha = c.material->base_alpha;
  const std::uint32_t* tri = &m.indices[3 * static_cast<std::size_t>(triangle)];
  const double b0 = 1.0 - b1 - b2;
  const std::vector<glm::vec2>& uvs = m.texcoord_set(c.material->base_color_uv.set);
  if (c.texture && !uvs.empty()) {
    const glm::dvec2 uv = b0 * glm::dvec2(uvs[tri[0]]) + b1 * glm::dvec2(uvs[tri[1]]) + b2 * glm::dvec2(uvs[tri[2]]);
    alpha *= c.texture->alpha_lookup(c.material->base_color_uv.apply(uv));
  }
  if (!m.colour_alphas.empty())
    alpha *= b0 * m.colour_alphas[tri[0]] + b1 * m.colour_alphas[tri[1]] + b2 * m.colour_alphas[tri[2]];
  return alpha;
}

double stochastic_alpha_sample(const float origin[3], const float direction[3], std::uint32_t geometry,
                               std::uint32_t triangle) {
  std::uint32_t w[6];
  std::memcpy(w, origin, 3 * sizeof(float));
  std::memcpy(w + 3, direction, 3 * sizeof(float));
  // Chained SplitMix64 finalisers (materials/base/sampling.h) over the primitive and the ray's bits.
  std::uint64_t h = mix64((static_cast<std::uint64_t>(geometry) << 32) | triangle);
  for (int i = 0; i < 6; i += 2) h = mix64(h ^ ((static_cast<std::uint64_t>(w[i]) << 32) | w[i + 1]));
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

bool keeps_hit(const AlphaCoverage& c, std::uint32_t triangle, double b1, double b2, const float origin[3],
               const float direction[3]) {
  switch (c.material->alpha_mode) {
    case AlphaMode::kOpaque:
      return true;
    case AlphaMode::kMask:
      return coverage_alpha(c, triangle, b1, b2) >= c.material->alpha_cutoff;
    case AlphaMode::kBlend:
      return stochastic_alpha_sample(origin, direction, c.geometry, triangle) < coverage_alpha(c, triangle, b1, b2);
  }
  return true;
}

double expected_coverage(const AlphaCoverage& c, std::uint32_t triangle, double b1, double b2) {
  switch (c.material->alpha_mode) {
    case AlphaMode::kOpaque:
      return 1.0;
    case AlphaMode::kMask:
      return coverage_alpha(c, triangle, b1, b2) >= c.material->alpha_cutoff ? 1.0 : 0.0;
    case AlphaMode::kBlend:
      return std::clamp(coverage_alpha(c, triangle, b1, b2), 0.0, 1.0);
  }
  return 1.0;
}

}  // namespace lamina
