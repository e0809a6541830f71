// A pinhole perspective camera (glTF "perspective": vertical field of view yfov; the image's
// aspect ratio is the output's width/height, not the file's aspectRatio), or an orthographic one
// (glTF "orthographic": parallel rays over a view of half-height ymag; the half-width is ymag x
// the output's aspect ratio, not xmag). Rays start on the camera's plane (znear is not used).
#pragma once

#include <string>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"

namespace lamina {

class Camera {
 public:
  Camera(const CameraDesc& desc, int width, int height);
  // The ray through film position (x, y) in pixels, from the top-left corner of the image.
  Ray generate_ray(glm::dvec2 film) const;

 private:
  glm::dvec3 origin_, forward_, right_, up_;
  double scale_x_, scale_y_;  // screen-window units per pixel (no division per ray)
  double tan_half_y_, aspect_;  // perspective: tan(yfov/2); orthographic: ymag
  bool orthographic_ = false;
};

// The camera `lamina render --camera NAME` means: the first whose name or whose node's name is
// NAME. Throws SceneError naming the scene and listing its cameras if there is none.
const CameraDesc& find_camera(const SceneDesc& scene, const std::string& name);

}  // namespace lamina
