// The scene as the integrator sees it: an Embree 3 BVH over the glTF meshes (one triangle
// geometry per mesh, geometry id = mesh index), and the surface data at a hit. Meshes of MASK
// and BLEND materials carry an Embree filter (alpha_coverage.h) that both intersect() and
// occluded() go through.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "renderer/scene/alpha_coverage.h"
#include "renderer/scene/scene_gltf.h"

namespace lamina {

struct Ray {
  glm::dvec3 origin;
  glm::dvec3 direction;  // unit length
};

// Every ray traced, for the benchmark's replay (bench/bench_render.cpp); normally absent.
struct RayLog {
  std::vector<Ray> closest;
  std::vector<std::pair<Ray, double>> shadow;  // with tmax
};

// Rays traced, counted by the caller's thread (one RayCounters per tile) and summed after.
struct RayCounters {
  std::uint64_t closest = 0;  // rtcIntersect1: camera and bounce rays
  std::uint64_t camera = 0;   // of which camera rays
  std::uint64_t shadow = 0;   // rtcOccluded1
  // Layered materials (random-walk mode): scattering events of the walks (their light
  // connections share the shading point's shadow rays, counted in `shadow`).
  std::uint64_t scatter_events = 0;
  RayLog* log = nullptr;      // if set, every ray is also recorded (single-threaded use only)
  RayCounters& operator+=(const RayCounters& o) {
    closest += o.closest; camera += o.camera; shadow += o.shadow;
    scatter_events += o.scatter_events;
    return *this;
  }
};

// What the integrator needs at a hit point.
struct SurfaceHit {
  double t = 0.0;
  glm::dvec3 p;    // on the triangle (barycentric), not origin + t d: tighter error bound
  glm::dvec3 ng;   // geometric normal, unit, as wound (not flipped towards the ray)
  glm::dvec3 ns;   // shading normal, unit, on the same side as ng
  glm::dvec2 uv{0.0};   // TEXCOORD_0
  glm::dvec2 uv1{0.0};  // TEXCOORD_1 (0 where the mesh has none)
  // The interpolated tangent frame of a normal-mapped mesh (Mesh::tangents): xyz, and w the
  // bitangent's sign; (0, 0, 0, 0) where there is none.
  glm::dvec4 tangent{0.0};
  glm::dvec3 colour{1.0};  // the interpolated COLOR_0 (Mesh::colours), 1 where there is none
  int mesh = -1;
  int triangle = -1;
};

// The shading normal perturbed by a tangent-space normal map (glTF 2.0 section 3.9.3: texel
// (r, g, b) in [0, 1] is the normal (2r - 1) s, (2g - 1) s, 2b - 1 in the frame T, B = w N x T,
// N, s the material's scale), unit, on the side of hit.ns. hit.ns if the hit has no tangent
// frame or the map's normal is unusable.
// uv: where to read the map (hit.uv through the material's KHR_texture_transform).
glm::dvec3 normal_mapped(const SurfaceHit& hit, const Texture& map, double scale, glm::dvec2 uv);

// Where a texture slot reads its texture: the hit's coordinates of the slot's set, through the
// slot's KHR_texture_transform.
inline glm::dvec2 texture_uv(const UvTransform& slot, const SurfaceHit& hit) {
  return slot.apply(slot.set == 1 ? hit.uv1 : hit.uv);
}

class Scene {
 public:
  explicit Scene(SceneDesc desc);
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  const SceneDesc& desc() const { return desc_; }
  // Closest hit along the ray in (0, tmax). Counts one closest-hit ray (in the caller's
  // counters: a reference, since every caller counts).
  bool intersect(const Ray& ray, SurfaceHit* hit, RayCounters& counters, double tmax = 1e300) const;
  // True if anything blocks the open segment (0, tmax) along the ray. Counts one shadow ray.
  bool occluded(const Ray& ray, double tmax, RayCounters& counters) const;
  // Bounding sphere of the geometry (for directional and environment lights).
  glm::dvec3 centre() const { return centre_; }
  double radius() const { return radius_; }
  // How much of a point of triangle `triangle` of mesh `mesh` (barycentrics b1, b2) a ray meets
  // on average: 1 for opaque meshes, else expected_coverage() of its alpha (alpha_coverage.h).
  double coverage(int mesh, int triangle, double b1, double b2) const;
  // The raw Embree scene handle (RTCScene) for the benchmark's ceiling loop.
  void* embree_scene() const { return scene_; }

 private:
  SceneDesc desc_;
  void* device_ = nullptr;  // RTCDevice
  void* scene_ = nullptr;   // RTCScene
  glm::dvec3 centre_{0.0};
  double radius_ = 0.0;
  std::vector<AlphaCoverage> alpha_;  // the filters' user data (sized once: Embree keeps pointers)
  std::vector<int> alpha_of_mesh_;    // index into alpha_ per mesh, -1 for opaque meshes
};

// A ray origin just off the surface at p, on the side of `n` (Waechter and Binder, "A Fast and
// Robust Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6): the offset grows
// with |p| in floating-point ulps, so it is enough at any scale yet never skips thin features.
glm::dvec3 offset_ray_origin(const glm::dvec3& p, const glm::dvec3& n);

}  // namespace lamina
