// The unidirectional path tracer: next-event estimation at every bounce, multiple importance
// sampling (power heuristic) between light and BSDF sampling, Russian roulette (pbrt-v4 13.4
// and 14.1; Veach's thesis ch. 9 for MIS).
//
// Determinism: sample s of pixel i draws all its random numbers from Rng(seed, i, s) and each
// pixel is summed in sample order by one task, so the image is bit-identical for any number
// of threads.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "materials/sampling.h"
#include "renderer/scene/camera.h"
#include "renderer/image/image.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/render/lights.h"
#include "renderer/scene/scene.h"

namespace lamina {

// Where a camera sample sits among the samples of its pixel, for the stratified hero channel:
// the k-th random walk of sample `sample` in pixel `pixel` uses hero (sample + o_k) mod 3, where
// the offset o_k is uniform on {0, 1, 2}, drawn from Rng(seed, pixel, kHeroStream + k): the same
// for every sample of the pixel, independent of each sample's own stream.
struct HeroStrata {
  static constexpr std::uint64_t kHeroStream = 1ull << 62;  // far above any sample index
  std::uint64_t seed = 0;
  std::uint64_t pixel = 0;
  std::uint64_t sample = 0;
  int hero(int walk_index) const;
};

struct RenderSettings {
  int width = 640;
  int height = 480;
  int spp = 16;
  std::uint64_t seed = 0;
  int max_depth = 64;  // bounces: 0 shows emitters and the environment only
  int threads = 0;     // 0: all cores
  RayLog* ray_log = nullptr;  // benchmark only: records every ray (forces one thread)
  const LayeredShading* layered = nullptr;  // null: no layered materials
};

struct RenderStats {
  RayCounters rays;
  std::uint64_t invalid_samples = 0;  // NaN/Inf path estimates, dropped (should stay 0)
};

// Radiance arriving at ray.origin along -ray.direction, estimated by one path.
// strata: null, or the sample's place in its pixel (stratified hero channels, if
// layered->stratified_hero); null makes every walk draw its own hero.
Spectrum path_radiance(const Scene& scene, const LightSet& lights, Ray ray, Rng& rng, int max_depth,
                       RayCounters* rays, const LayeredShading* layered = nullptr,
                       const HeroStrata* strata = nullptr);

// Renders the image; on_progress (optional, thread-safe) receives the samples done per tile.
Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& settings,
                   RenderStats* stats, const std::function<void(std::uint64_t)>& on_progress = {});

// A film offset in [-1, 1]^2 distributed as the tent filter of radius 1 pixel, so each
// sample has weight 1 (filter importance sampling, pbrt-v4 8.8.1).
glm::dvec2 sample_tent_filter(glm::dvec2 u);

}  // namespace lamina
