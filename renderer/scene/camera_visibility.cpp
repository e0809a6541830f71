#include "renderer/scene/camera_visibility.h"

#include <algorithm>

namespace lamina {

std::vector<bool> camera_visible_materials(const Scene& scene, const Camera& camera, int width, int height, int grid) {
  const SceneDesc& desc = scene.desc();
  std::vector<bool> seen(desc.materials.size(), false);
  const int nx = std::min(width, grid), ny = std::min(height, grid);
  RayCounters rays;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      // The centre of cell (i, j) of an nx x ny grid over the film, in pixels.
      const glm::dvec2 film((i + 0.5) * width / nx, (j + 0.5) * height / ny);
      SurfaceHit hit;
      if (!scene.intersect(camera.generate_ray(film), &hit, rays)) continue;
      const int m = desc.meshes[hit.mesh].material;
      if (m >= 0 && m < static_cast<int>(seen.size())) seen[m] = true;
    }
  return seen;
}

}  // namespace lamina
