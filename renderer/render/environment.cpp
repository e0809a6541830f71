// The environment map (see environment.h).
//
// Lookup: nearest pixel. The radiance is a step function over the map's pixels, and the
// sampling density is a step function in (u, v) over the same pixels (times the Jacobian
// 1/(2 pi^2 sin theta)), so pdf > 0 exactly where eval > 0: no pixel that contributes is ever
// missed, no pixel that is black is ever sampled. The weight w = lum * mean_row(sin theta)
// makes the estimator's ratio bounded whatever the map's contrast:
//   L/pdf = L * 2 pi^2 sin(theta) * I / w = (L/lum) * (sin theta / mean_row sin) * 2 pi^2 I,
// with I the distribution's integral, L/lum <= 1/0.0722 per channel and sin/mean sin <= 2 (the
// worst case is the polar rows, where sin grows linearly across the row). Bilinear lookup would spread a pixel's radiance into its neighbours'
// cells, where a black neighbour would have pdf = 0 and the estimator would be biased unless
// the distribution were widened to cover that support (pbrt-v4 section 12.5.2 does this).
#include "renderer/render/environment.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "materials/base/sampling.h"
#include "renderer/render/distribution.h"
#include "renderer/image/image_io.h"
#include "renderer/scene/scene_gltf.h"  // kMaxLightStrength

namespace lamina {

struct EnvironmentMap::Data {
  enum class Kind { kConstant, kMap } kind = Kind::kConstant;
  Spectrum radiance;            // kConstant
  Image image;                  // kMap: linear RGB, nearest lookup
  Distribution2D distribution;  // kMap: luminance times the row's mean sin(theta)
};

namespace {

// Rec. 709 luminance (ITU-R BT.709): positive weights, so zero only for black.
double luminance(const float* rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

// Map coordinates of a unit direction (the convention in environment.h).
glm::dvec2 direction_to_uv(const glm::dvec3& d) {
  const double u = 0.5 + std::atan2(d.x, -d.z) * (0.5 * kInvPi);
  const double v = std::acos(std::clamp(d.y, -1.0, 1.0)) * kInvPi;
  return {u, v};
}

// Inverse of direction_to_uv: theta = pi v from +Y, phi = 2 pi (u - 1/2) from -Z towards +X.
glm::dvec3 uv_to_direction(const glm::dvec2& uv, double* sin_theta) {
  const double theta = kPi * uv.y, phi = 2.0 * kPi * (uv.x - 0.5);
  const double s = std::sin(theta);
  *sin_theta = s;
  return {s * std::sin(phi), std::cos(theta), -s * std::cos(phi)};
}

const float* lookup(const Image& image, const glm::dvec2& uv) {
  const int x = std::clamp(static_cast<int>(uv.x * image.width), 0, image.width - 1);
  const int y = std::clamp(static_cast<int>(uv.y * image.height), 0, image.height - 1);
  return image.pixel(x, y);
}

Spectrum to_spectrum(const float* rgb) { return {rgb[0], rgb[1], rgb[2]}; }

glm::dvec3 unit(const glm::dvec3& d) {
  const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  return len > 0.0 ? d / len : glm::dvec3(0.0, 1.0, 0.0);
}

// Parses a whole string as one finite-or-not number; false if anything else is in it.
bool parse_number(const std::string& text, double* value) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(begin, &end);
  if (end == begin) return false;
  while (*end == ' ' || *end == '\t') ++end;
  return *end == '\0';
}

}  // namespace

EnvironmentMap::EnvironmentMap() = default;

EnvironmentMap EnvironmentMap::constant(const Spectrum& radiance) {
  if (!radiance.is_finite() || radiance.min() < 0.0)
    throw std::invalid_argument("environment radiance must be finite and non-negative");
  EnvironmentMap env;
  if (radiance.is_black()) return env;
  auto data = std::make_shared<Data>();
  data->kind = Data::Kind::kConstant;
  data->radiance = radiance;
  env.data_ = std::move(data);
  return env;
}

EnvironmentMap EnvironmentMap::from_file(const std::string& path) {
  Image image = read_image(path);  // throws ImageIoError naming the file
  const int w = image.width, h = image.height;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = image.pixel(x, y)[c];
        if (!std::isfinite(v) || v < 0.0f)
          throw ImageIoError("environment map '" + path + "': pixel (" + std::to_string(x) + ", " +
                             std::to_string(y) + ") is negative or not finite");
        if (v > kMaxLightStrength)
          throw ImageIoError("environment map '" + path + "': pixel (" + std::to_string(x) + ", " +
                             std::to_string(y) + ") is above the largest light strength, " + light_strength_limit());
      }
  // Weight of pixel (x, y): its luminance times the mean of sin(theta) over its row, so the
  // probability of a pixel is proportional to luminance times its solid angle:
  //   solid angle of a pixel = (2 pi / w) * (cos theta0 - cos theta1),
  //   mean sin over the row  = (cos theta0 - cos theta1) / (theta1 - theta0).
  std::vector<double> weight(static_cast<std::size_t>(w) * h);
  bool any = false;
  for (int y = 0; y < h; ++y) {
    const double theta0 = kPi * y / h, theta1 = kPi * (y + 1) / h;
    const double mean_sin = (std::cos(theta0) - std::cos(theta1)) / (theta1 - theta0);
    for (int x = 0; x < w; ++x) {
      weight[static_cast<std::size_t>(y) * w + x] = luminance(image.pixel(x, y)) * mean_sin;
      any |= weight[static_cast<std::size_t>(y) * w + x] > 0.0;
    }
  }
  EnvironmentMap env;
  if (!any) return env;  // an all-black map is no environment
  auto data = std::make_shared<Data>();
  data->kind = Data::Kind::kMap;
  data->distribution = Distribution2D(weight, static_cast<std::size_t>(w), static_cast<std::size_t>(h));
  data->image = std::move(image);
  env.data_ = std::move(data);
  return env;
}

EnvironmentMap EnvironmentMap::from_argument(const std::string& value) {
  if (value.empty()) throw std::invalid_argument("--env '': empty value (a number, R,G,B or an EXR/HDR file)");
  // Split at commas; one or three numeric parts are a radiance, anything else a path.
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t comma; (comma = value.find(',', start)) != std::string::npos; start = comma + 1)
    parts.push_back(value.substr(start, comma - start));
  parts.push_back(value.substr(start));
  std::vector<double> numbers;
  for (const std::string& p : parts) {
    double x;
    if (parse_number(p, &x)) numbers.push_back(x);
  }
  if (numbers.size() == parts.size()) {
    if (parts.size() != 1 && parts.size() != 3)
      throw std::invalid_argument("--env '" + value + "': expected a number or R,G,B, not " +
                                  std::to_string(parts.size()) + " numbers");
    for (double x : numbers)
      if (!std::isfinite(x) || x < 0.0)
        throw std::invalid_argument("--env '" + value + "': radiance must be finite and non-negative");
      else if (x > kMaxLightStrength)
        throw std::invalid_argument("--env '" + value + "': radiance is above the largest light strength, " +
                                    light_strength_limit());
    return constant(parts.size() == 1 ? Spectrum(numbers[0]) : Spectrum(numbers[0], numbers[1], numbers[2]));
  }
  if (std::filesystem::exists(value)) return from_file(value);
  if (!numbers.empty())
    throw std::invalid_argument("--env '" + value + "': malformed R,G,B (and no such file)");
  throw std::invalid_argument("--env '" + value + "': not a number, not R,G,B, and no such file");
}

bool EnvironmentMap::is_black() const { return !data_; }

Spectrum EnvironmentMap::eval(const glm::dvec3& d) const {
  if (!data_) return Spectrum();
  if (data_->kind == Data::Kind::kConstant) return data_->radiance;
  return to_spectrum(lookup(data_->image, direction_to_uv(unit(d))));
}

Spectrum EnvironmentMap::sample(const glm::dvec2& u, glm::dvec3* d, double* pdf) const {
  if (!data_) {
    *d = glm::dvec3(0.0, 1.0, 0.0);
    *pdf = 0.0;
    return Spectrum();
  }
  if (data_->kind == Data::Kind::kConstant) {
    *d = sample_uniform_sphere(u);
    *pdf = kInv4Pi;
    return data_->radiance;
  }
  double pdf_uv = 0.0;
  std::size_t ix = 0, iy = 0;
  const glm::dvec2 uv = data_->distribution.sample(u, &pdf_uv, &ix, &iy);
  double sin_theta = 0.0;
  *d = uv_to_direction(uv, &sin_theta);
  // d omega = sin(theta) d theta d phi = 2 pi^2 sin(theta) du dv, so the solid-angle density is
  // pdf_uv / (2 pi^2 sin theta). At the poles
  // sin theta = 0 and the density is infinite: reject those samples.
  if (pdf_uv <= 0.0 || sin_theta <= 0.0) {
    *pdf = 0.0;
    return Spectrum();
  }
  *pdf = pdf_uv / (2.0 * kPi * kPi * sin_theta);
  return to_spectrum(data_->image.pixel(static_cast<int>(ix), static_cast<int>(iy)));
}

double EnvironmentMap::pdf(const glm::dvec3& direction) const {
  if (!data_) return 0.0;
  if (data_->kind == Data::Kind::kConstant) return kInv4Pi;
  const glm::dvec3 d = unit(direction);
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - d.y * d.y));
  if (sin_theta <= 0.0) return 0.0;
  return data_->distribution.pdf(direction_to_uv(d)) / (2.0 * kPi * kPi * sin_theta);
}

}  // namespace lamina
