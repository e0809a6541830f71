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
#include "renderer/layered/layered_material.h"
#include "renderer/render/lights.h"
#include "renderer/scene/scene.h"

namespace lamina {

class LayeredTables;

// How layered materials are shaded (renderer/surfaces/layered_surface.h).
struct LayeredShading {
  const LayeredBindings* bindings = nullptr;
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;
  // `--subsurface auto`: the mode of each glTF material slot (renderer/layered/subsurface_auto.h);
  // empty: `mode` for every material.
  std::vector<SubsurfaceMode> per_material;
  SubsurfaceMode mode_for(int material) const {
    return material >= 0 && material < static_cast<int>(per_material.size()) ? per_material[material] : mode;
  }
  // Tests and the bias report only: the naive random-walk estimator of the seed's slides. Light
  // samples at events without the Fresnel transmission of the way out and with weight 1, and
  // the walk's exits that reach a light also with weight 1 (no MIS: counted twice).
  bool naive = false;
  // Measurements only: light samples at events with weight 1 and the walk's straight exits
  // ignored when they reach a light (unbiased, no MIS), to show what MIS buys at g -> 1.
  bool connections_only = false;
  const LayeredTables* tables = nullptr;  // SubsurfaceMode::Table
  // random-walk mode: the hero channel of each walk stratified over the samples of a pixel
  // (HeroStrata below; integrator.cpp has the derivation). false: every walk draws its hero
  // independently (the library's default), kept for the tests and the noise measurements.
  bool stratified_hero = true;
};

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
