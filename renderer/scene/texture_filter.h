// Bilinear texture filtering shared by colour textures (scene_gltf) and parameter maps
// (stack_bindings): one definition of where the texels are and how much each one weighs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <glm/vec2.hpp>

namespace lamina {

// The four texels around uv and their bilinear weights. Texel centres sit at (i + 0.5) / size
// (glTF follows OpenGL sampling); v = 0 is the top row. Each axis either repeats or clamps to
// the edge. Returns false (no texels) for non-finite uv.
struct BilinearFootprint {
  std::size_t texel[4];  // row-major indices: y * width + x
  double weight[4];
};

inline bool bilinear_footprint(glm::dvec2 uv, int width, int height, bool clamp_s, bool clamp_t,
                               BilinearFootprint* f) {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return false;
  // i is in [-1, n] (x below is in [-0.5, n - 0.5]), so repeat needs one add or subtract, not
  // an integer division (which was a visible share of the render loop on textured meshes).
  auto wrap = [](int i, int n, bool clamp) {
    if (clamp) return std::clamp(i, 0, n - 1);
    return i < 0 ? i + n : i >= n ? i - n : i;
  };
  // Keep coordinates in int range: repeat wraps uv to [0, 1); clamp clamps it (the same texels).
  const double u = clamp_s ? std::clamp(uv.x, 0.0, 1.0) : uv.x - std::floor(uv.x);
  const double v = clamp_t ? std::clamp(uv.y, 0.0, 1.0) : uv.y - std::floor(uv.y);
  const double x = u * width - 0.5, y = v * height - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const double tx = x - fx, ty = y - fy;
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int k = dy * 2 + dx;
      f->weight[k] = (dx ? tx : 1.0 - tx) * (dy ? ty : 1.0 - ty);
      f->texel[k] = static_cast<std::size_t>(wrap(y0 + dy, height, clamp_t)) * width +
                    wrap(x0 + dx, width, clamp_s);
    }
  return true;
}

}  // namespace lamina
