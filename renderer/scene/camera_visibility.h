// What the camera sees directly, found cheaply before rendering (--subsurface auto predicts only
// the layered materials the camera sees).
#pragma once

#include <vector>

#include "renderer/scene/camera.h"
#include "renderer/scene/scene.h"

namespace lamina {

// Which glTF material slots the camera sees directly: camera rays through a grid of at most
// grid x grid film positions over the whole image (pixel centres of a coarse grid; all pixels
// if the image is smaller). Materials seen only indirectly (through a transmitting stack, in
// reflections, by their light on other surfaces) are NOT found.
std::vector<bool> camera_visible_materials(const Scene& scene, const Camera& camera, int width, int height, int grid = 64);

}  // namespace lamina
