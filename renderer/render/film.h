// The film: the image a render accumulates, and the scheduler that fills it (tiles, rounds,
// adaptive sampling, the time limit, previews, AOVs), apart from the path tracer it drives
// (renderer/render/integrator.h).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <vector>

#include <glm/vec2.hpp>

#include "renderer/image/image.h"
#include "renderer/render/lights.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/scene.h"

namespace lamina {

struct LayeredShading;

// The feature images (AOVs) a render keeps besides the colour, each averaged over the pixel's
// samples like the colour (docs/contracts.md, "AOVs"). Off by default: a render pays for what it
// asks for.
struct AovSelection {
  bool albedo = false;    // one-sample estimate of the first hit's directional albedo (FirstHit)
  bool normal = false;    // the first hit's shading normal, world space, towards the camera
  bool depth = false;     // distance from the camera to the first hit along the ray
  bool variance = false;  // per channel, the variance of the pixel's mean (sample variance / n)
  bool any() const { return albedo || normal || depth || variance; }
};

// A rectangle of pixels [x0, x1) x [y0, y1) of the full image; empty (x1 <= x0) is the whole.
struct PixelRegion {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x1 <= x0 || y1 <= y0; }
};

// Switches for tests and benchmarks only; production leaves them as they are.
struct RenderTestHooks {
  RayLog* ray_log = nullptr;  // records every ray (forces one thread): bench_render's replay
};

struct RenderSettings {
  int width = 640;
  int height = 480;
  int spp = 16;
  std::uint64_t seed = 0;
  int max_depth = 64;  // bounces: 0 shows emitters and the environment only
  int threads = 0;     // 0: all cores
  const LayeredShading* layered = nullptr;  // null: no layered materials
  // Adaptive sampling (film.cpp has the scheme): 0 = off; else the target relative standard
  // error of each pixel's mean luminance, with `spp` the most samples a pixel gets and
  // `pilot_spp` the samples of the pilot pass from which each pixel's NEIGHBOURS are planned
  // (they stay in the image).
  double noise_threshold = 0.0;
  int pilot_spp = 16;
  // Wall-clock budget of the render loop in seconds (0: none): the samples are rendered in
  // rounds over the whole image, and rounds stop when the budget is spent (the first round
  // always completes, so every pixel has samples). Not deterministic (it depends on the speed).
  double time_limit = 0.0;
  AovSelection aovs;
  // --crop: only these pixels are rendered (the image is the region's size), each exactly as in
  // the full image (the same random streams, and with adaptive sampling the same plan).
  PixelRegion crop;
  // Seconds between progressive previews (RenderProgress::preview); 0: none. Samples are then
  // rendered in rounds over the whole image, which gives the same image as one pass.
  double preview_every = 0.0;
  // --clamp: BIASED firefly suppression (0: off). A path sample whose largest channel exceeds it
  // is scaled down to it (hue kept); the light removed is lost, not redistributed.
  double clamp = 0.0;
  // The spectral mode (renderer/render/spectral_option.h): each path carries three sampled
  // wavelengths and the film converts its radiance to linear Rec. 709 through CIE XYZ.
  bool spectral = false;
  RenderTestHooks test_hooks;
};

// The AOV images of a render (those selected in RenderSettings::aovs; the others stay empty),
// each the size of the rendered image. Pixels whose camera rays miss every surface have albedo,
// normal and depth 0.
struct RenderAovs {
  Image albedo, normal, variance;
  std::vector<float> depth;
};

struct RenderStats {
  RayCounters rays;
  std::uint64_t invalid_samples = 0;  // NaN/Inf path estimates, dropped (should stay 0)
  std::uint64_t clamped_samples = 0;  // path samples scaled down by RenderSettings::clamp
  // With adaptive sampling or a time limit: each pixel's number of samples in the image (row
  // major; empty otherwise), how many of them the pilot pass rendered, and whether the time limit
  // stopped the render before every pixel had its planned samples.
  std::vector<std::uint32_t> pixel_samples;
  std::uint64_t pilot_samples = 0;
  bool time_limit_reached = false;
  double converged_fraction = 0.0;  // pixels whose planned count is below spp (adaptive)
};

// Progress of a render: samples done (per tile), and, for adaptive sampling, the planned total
// once the pilot pass has decided it, with the fraction of pixels that converge before spp.
struct RenderProgress {
  std::function<void(std::uint64_t samples)> advance;
  std::function<void(std::uint64_t total_samples, double converged_fraction)> planned;
  // With RenderSettings::preview_every: the image so far (each pixel the mean of its samples so
  // far) and the samples in it, called between rounds from the rendering thread.
  std::function<void(const Image& image, std::uint64_t samples)> preview;
  // Set from any thread to stop the render: it is read before each sample (never changing one),
  // so the render stops within one path of each worker, and render_image throws RenderCancelled.
  const std::atomic<bool>* cancel = nullptr;
};

// What render_image throws when RenderProgress::cancel stopped it.
struct RenderCancelled : std::runtime_error {
  RenderCancelled() : std::runtime_error("render cancelled") {}
};

// Renders the image; on_progress (optional, thread-safe) receives the samples done per tile.
Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& settings,
                   RenderStats* stats, const std::function<void(std::uint64_t)>& on_progress = {});
Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& settings,
                   RenderStats* stats, const RenderProgress& progress, RenderAovs* aovs = nullptr);

// The samples per pixel a render takes whatever its time limit: the first round (or the
// adaptive pilot), which always completes.
int first_round_samples(const RenderSettings& settings);

// A film offset in [-1, 1]^2 distributed as the tent filter of radius 1 pixel, so each
// sample has weight 1 (filter importance sampling, pbrt-v4 8.8.1).
glm::dvec2 sample_tent_filter(glm::dvec2 u);

}  // namespace lamina
