// Image: a linear RGB float raster, row-major from the top-left pixel, 3 floats a pixel.
// Reading and writing files (EXR, HDR, PNG, JPEG) is image_io.h.
#pragma once

#include <cstddef>
#include <vector>

namespace lamina {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // width * height * 3

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3, 0.0f) {}
  float* pixel(int x, int y) { return &rgb[(static_cast<std::size_t>(y) * width + x) * 3]; }
  const float* pixel(int x, int y) const { return &rgb[(static_cast<std::size_t>(y) * width + x) * 3]; }
};

}  // namespace lamina
