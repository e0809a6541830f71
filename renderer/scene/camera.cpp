#include "renderer/scene/camera.h"

#include <cmath>

#include <glm/geometric.hpp>

namespace lamina {

Camera::Camera(const CameraDesc& desc, int width, int height)
    : origin_(desc.position),
      forward_(glm::normalize(desc.forward)),
      tan_half_y_(desc.orthographic ? desc.ymag : std::tan(0.5 * desc.yfov)),
      aspect_(static_cast<double>(width) / height),
      orthographic_(desc.orthographic) {
  scale_x_ = 2.0 * tan_half_y_ * aspect_ / width;
  scale_y_ = 2.0 * tan_half_y_ / height;
  right_ = glm::cross(forward_, desc.up);
  if (glm::length(right_) < 1e-9) right_ = glm::cross(forward_, glm::dvec3(1.0, 0.0, 0.0));  // up || forward
  right_ = glm::normalize(right_);
  up_ = glm::cross(right_, forward_);
}

Ray Camera::generate_ray(glm::dvec2 film) const {
  // Screen window [-aspect, aspect] x [-1, 1], scaled by tan(yfov/2) at unit distance
  // (perspective) or by ymag on the camera's plane (orthographic).
  const double sx = film.x * scale_x_ - tan_half_y_ * aspect_;
  const double sy = tan_half_y_ - film.y * scale_y_;
  if (orthographic_) return {origin_ + sx * right_ + sy * up_, forward_};
  return {origin_, glm::normalize(forward_ + sx * right_ + sy * up_)};
}

const CameraDesc& find_camera(const SceneDesc& scene, const std::string& name) {
  std::string names;
  for (const CameraDesc& c : scene.cameras) {
    if (c.name == name || c.node_name == name) return c;
    names += (names.empty() ? "" : ", ") + ("'" + c.name + "'");
  }
  throw SceneError(scene.path + ": no camera named '" + name + "' (cameras: " + (names.empty() ? "none" : names) + ")");
}

}  // namespace lamina
