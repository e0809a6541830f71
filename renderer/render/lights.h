// Lights: a small interface for next-event estimation, one class per kind, and the light set
// that chooses among them in proportion to their (approximate) power.
//
// sample_li() returns the incident radiance Li arriving at p from direction wi (towards the
// light) with the solid-angle density pdf; for delta lights (point, spot, directional) pdf is 1
// and Li is the irradiance on a surface facing the light divided by 1 (the "per delta"
// convention of pbrt-v4 12.1), so f |cos| Li / pdf is the right estimate either way.
#pragma once

#include <memory>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"
#include "renderer/render/distribution.h"
#include "renderer/render/environment.h"
#include "renderer/scene/scene.h"

namespace lamina {

struct LightSample {
  Spectrum li;
  glm::dvec3 wi{0.0};     // unit, from p towards the light
  glm::dvec3 target{0.0}; // the point on the light, offset off its surface (finite lights)
  bool infinite = false;  // directional or environment: the shadow ray has no end
  double pdf = 0.0;       // solid angle (1 for delta lights)
};

class Light {
 public:
  virtual ~Light() = default;
  virtual bool sample_li(const glm::dvec3& p, glm::dvec2 u, LightSample* s) const = 0;
  // Solid-angle density with which sample_li() would choose direction wi from p, given what a
  // ray from p along wi hit (`hit` is null when it escaped the scene). 0 for delta lights.
  virtual double pdf_li(const glm::dvec3& p, const glm::dvec3& wi, const SurfaceHit* hit) const = 0;
  virtual bool is_delta() const = 0;
  // Emitted power, W (the light-selection weight; approximate where stated).
  virtual double power() const = 0;
  std::size_t id = 0;  // index in its LightSet
};

// Radiance leaving an emissive triangle towards w at a hit: emission x texture, on the front
// face (the side ng points to), or both faces for a double-sided material.
Spectrum emitted_radiance(const Scene& scene, const SurfaceHit& hit, const glm::dvec3& w);

// How next-event estimation samples the lights: every delta light (point, spot, directional)
// is sampled at every shading point, as long as there are at most kMaxLightsSampledEach of
// them; one more sample is drawn from the rest (the "pool": emissive triangles, the
// environment, and delta lights beyond that number) with probability proportional to power.
// The sum of these estimators is unbiased; sampling the few punctual lights of a portrait each
// removes the noise of choosing between them, and a layered walk connects all its events to the
// same few samples (renderer/render/integrator.cpp).
class LightSet {
 public:
  static constexpr std::size_t kMaxLightsSampledEach = 8;

  LightSet(const Scene& scene, const EnvironmentMap& environment);
  bool empty() const { return lights_.empty(); }
  std::size_t size() const { return lights_.size(); }
  // The lights sampled at every shading point (each with probability 1).
  const std::vector<const Light*>& sampled_each() const { return sampled_each_; }
  bool pool_empty() const { return pool_.empty(); }
  // Chooses a light of the pool with probability pmf (proportional to power); null if the pool
  // is empty.
  const Light* choose(double u, double* pmf) const;
  // The probability with which choose() picks `light` (0 for a light sampled each time).
  double pmf(const Light* light) const;
  // The light of an emissive triangle (null if it does not emit), and the environment's (null
  // if it is black).
  const Light* triangle_light(int mesh, int triangle) const;
  const Light* environment() const { return environment_; }
  const EnvironmentMap& environment_map() const { return environment_map_; }

 private:
  std::vector<std::unique_ptr<Light>> lights_;
  std::vector<const Light*> sampled_each_;
  std::vector<const Light*> pool_;
  std::vector<double> pmf_;  // by Light::id
  Distribution1D distribution_;  // over pool_
  std::vector<std::vector<int>> triangle_light_;  // [mesh][triangle] -> light index or -1
  const Light* environment_ = nullptr;
  EnvironmentMap environment_map_;
};

}  // namespace lamina
