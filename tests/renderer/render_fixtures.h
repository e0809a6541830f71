// Scene-building fixtures shared by the renderer tests: meshes built in code (the glTF loader
// has its own tests), a SceneDesc around them, and the mean and standard error of an image.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>
#include <gtest/gtest.h>

#include "materials/base/sampling.h"
#include "materials/base/spectrum.h"
#include "renderer/render/film.h"
#include "renderer/scene/scene_gltf.h"

namespace lamina::test {

// Appends the quad a b c d as two triangles (a b c, a c d); its normal follows the winding.
inline void add_quad(Mesh* m, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
  const auto base = static_cast<std::uint32_t>(m->positions.size());
  // push_back rather than insert of a brace list: GCC 12 gives a false -Wstringop-overflow there.
  for (const glm::vec3& v : {a, b, c, d}) m->positions.push_back(v);
  m->indices.insert(m->indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// The cube [-1, 1]^3 (outward winding).
inline Mesh cube(int material) {
  Mesh m;
  m.material = material;
  const float s = 1.0f;
  add_quad(&m, {-s, -s, s}, {s, -s, s}, {s, s, s}, {-s, s, s});
  add_quad(&m, {s, -s, -s}, {-s, -s, -s}, {-s, s, -s}, {s, s, -s});
  add_quad(&m, {s, -s, s}, {s, -s, -s}, {s, s, -s}, {s, s, s});
  add_quad(&m, {-s, -s, -s}, {-s, -s, s}, {-s, s, s}, {-s, s, -s});
  add_quad(&m, {-s, s, s}, {s, s, s}, {s, s, -s}, {-s, s, -s});
  add_quad(&m, {-s, -s, -s}, {s, -s, -s}, {s, -s, s}, {-s, -s, s});
  return m;
}

// A UV sphere of radius 1 with vertices on the sphere (triangles at the poles, no degenerate
// ones), outward winding.
inline Mesh sphere(int material, int rings, int segments) {
  Mesh m;
  m.material = material;
  m.positions.push_back({0.0f, 1.0f, 0.0f});
  for (int i = 1; i < rings; ++i) {
    const double theta = kPi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * kPi * j / segments;
      m.positions.push_back(glm::vec3(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)));
    }
  }
  m.positions.push_back({0.0f, -1.0f, 0.0f});
  const auto south = static_cast<std::uint32_t>(m.positions.size() - 1);
  auto v = [&](int ring, int j) { return static_cast<std::uint32_t>(1 + (ring - 1) * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) {
    m.indices.insert(m.indices.end(), {0u, v(1, j + 1), v(1, j)});
    m.indices.insert(m.indices.end(), {south, v(rings - 1, j), v(rings - 1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i)
      m.indices.insert(m.indices.end(), {v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i + 1, j)});
  }
  return m;
}

// A scene description of the given meshes and materials (bounds computed).
inline SceneDesc make_scene(std::vector<Mesh> meshes, std::vector<Material> materials) {
  SceneDesc d;
  d.path = "test";
  d.meshes = std::move(meshes);
  d.materials = std::move(materials);
  d.compute_bounds();
  return d;
}

// The same with `material_count` default materials (for scenes whose shading is bound elsewhere).
inline SceneDesc make_scene(std::vector<Mesh> meshes, int material_count = 1) {
  return make_scene(std::move(meshes), std::vector<Material>(static_cast<std::size_t>(material_count)));
}

// A camera at `position` looking along `forward` with a vertical field of view in degrees.
inline CameraDesc camera_at(glm::dvec3 position, glm::dvec3 forward, double yfov_deg) {
  CameraDesc c;
  c.position = position;
  c.forward = forward;
  c.up = std::abs(forward.y) > 0.9 ? glm::dvec3(0.0, 0.0, -1.0) : glm::dvec3(0.0, 1.0, 0.0);
  c.yfov = yfov_deg * kPi / 180.0;
  return c;
}

// A Lambert plane y = 0 of the given colour (200 x 200 around the origin).
inline SceneDesc lambert_plane(const Spectrum& albedo) {
  Material mat;
  mat.base_color = albedo;
  Mesh plane;
  add_quad(&plane, {-100, 0, 100}, {100, 0, 100}, {100, 0, -100}, {-100, 0, -100});
  plane.material = 0;
  return make_scene({plane}, {mat});
}

// `scene` under `env` seen by `cam`, rendered with `s` (its size the camera's image), every path
// sample valid (a test failure otherwise); stats_out, if given, receives the render's statistics.
inline Image render_valid(const Scene& scene, const EnvironmentMap& env, const CameraDesc& cam, const RenderSettings& s,
                          RenderStats* stats_out = nullptr) {
  const LightSet lights(scene, env);
  const Camera camera(cam, s.width, s.height);
  RenderStats stats;
  Image im = render_image(scene, lights, camera, s, &stats);
  EXPECT_EQ(stats.invalid_samples, 0u);
  if (stats_out) *stats_out = stats;
  return im;
}

// Per channel, the mean of an image's pixels and its standard error s / sqrt(N), s the pixels'
// sample standard deviation (each pixel an independent estimate of the same expected value).
struct ImageStats {
  Spectrum mean, stderr_;
};

inline ImageStats stats_of(const Image& im) {
  ImageStats s;
  const double n = static_cast<double>(im.width) * im.height;
  for (int c = 0; c < 3; ++c) {
    double sum = 0.0, sum2 = 0.0;
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x) {
        const double v = im.pixel(x, y)[c];
        sum += v;
        sum2 += v * v;
      }
    s.mean[c] = sum / n;
    s.stderr_[c] = std::sqrt(std::max(0.0, (sum2 - n * s.mean[c] * s.mean[c]) / (n - 1.0)) / n);
  }
  return s;
}

// ---- A flat slab seen along one direction (the layered and auto tests) ----

// The plane y = 0, wound so that its normal (the stack's top) is +y.
inline Mesh slab_plane(int material) {
  Mesh m;
  m.material = material;
  add_quad(&m, {-1000, 0, 1000}, {1000, 0, 1000}, {1000, 0, -1000}, {-1000, 0, -1000});
  return m;
}

// A camera at distance 5 looking at the origin from the unit direction `from` (towards the
// camera), with a tiny field of view: every pixel sees the slab along the same direction (the
// direction varies by < 1e-4 rad over the image).
inline CameraDesc camera_towards(glm::dvec3 from) {
  CameraDesc c;
  c.position = 5.0 * from;
  c.forward = -from;
  c.up = std::abs(from.z) > 0.9 ? glm::dvec3(0.0, 1.0, 0.0) : glm::dvec3(0.0, 0.0, 1.0);
  c.yfov = 0.01 * kPi / 180.0;
  return c;
}

// World direction at polar angle theta (degrees) from +y (the slab's top normal), azimuth phi
// from +x towards +z; below the slab if `below`.
inline glm::dvec3 world_dir(double theta_deg, double phi_deg, bool below = false) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return {std::sin(t) * std::cos(p), below ? -std::cos(t) : std::cos(t), std::sin(t) * std::sin(p)};
}

}  // namespace lamina::test
