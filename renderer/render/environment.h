// The environment: radiance arriving from infinitely far away along rays that leave the scene.
// A constant colour, or an equirectangular (latitude-longitude) EXR/HDR map, importance
// sampled by a piecewise-constant 2D distribution over the map weighted by sin(theta)
// (pbrt-v4 section 12.5.2).
//
// Convention (glTF is +Y up): a world direction d maps to
//   u = 0.5 + atan2(d.x, -d.z) / (2 pi),  v = acos(d.y) / pi,
// so the map's centre looks down -Z and its top row is straight up.
//
// Lookup is nearest-pixel, the radiance a step function over pixels; the sampling density is a
// step function over the same pixels (weight: luminance times the pixel's solid angle), so
// pdf > 0 exactly where eval > 0 (see environment.cpp for why not bilinear).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"

namespace lamina {

class EnvironmentMap {
 public:
  // Black: no environment (the default, docs/contracts.md `--env`).
  EnvironmentMap();
  // Throws std::invalid_argument for negative or non-finite radiance.
  static EnvironmentMap constant(const Spectrum& radiance);
  // Throws ImageIoError naming the file on failure (unreadable, negative or non-finite pixel).
  // An all-black map gives the black environment.
  static EnvironmentMap from_file(const std::string& path);
  // Parses the `--env` value: a number, "R,G,B", or a path to an EXR/HDR file. Throws
  // std::invalid_argument (one line, quoting the value) for malformed, negative or NaN values
  // and missing files, ImageIoError for unreadable files.
  static EnvironmentMap from_argument(const std::string& value);

  bool is_black() const;
  // Radiance arriving along -d (d points from the scene towards the sky).
  Spectrum eval(const glm::dvec3& d) const;
  // Samples a direction d towards the sky with density pdf (solid angle); returns eval(d).
  Spectrum sample(const glm::dvec2& u, glm::dvec3* d, double* pdf) const;
  double pdf(const glm::dvec3& d) const;

 private:
  struct Data;
  std::shared_ptr<const Data> data_;
};

}  // namespace lamina
