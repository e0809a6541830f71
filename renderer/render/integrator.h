// The unidirectional path tracer: next-event estimation at every bounce, multiple importance
// sampling (power heuristic) between light and BSDF sampling, Russian roulette (pbrt-v4 13.4
// and 14.1; Veach's thesis ch. 9 for MIS). It knows Surfaces, not materials: Shading
// (renderer/layered/shading.h) gives it the surface at each hit. The film that drives it over the
// pixels is renderer/render/film.h.
//
// Determinism: sample s of pixel i draws all its random numbers from Rng(seed, i, s) and each
// pixel is summed in sample order by one task, so the image is bit-identical for any number
// of threads.
#pragma once

#include <glm/vec3.hpp>

#include "materials/base/sampling.h"
#include "materials/base/spectrum.h"
#include "renderer/layered/shading.h"
#include "renderer/render/lights.h"
#include "renderer/scene/scene.h"

namespace lamina {

// What the first surface a camera ray meets looks like (for the AOVs). The albedo is the weight
// of the surface's own continuation sample, f |cos| / pdf: its expectation is the directional
// albedo at the camera's direction, for any surface, a layered walk's (reflection and
// transmission) included, and it costs nothing since the path samples it anyway.
struct FirstHit {
  bool hit = false;
  double distance = 0.0;
  glm::dvec3 normal{0.0};
  Spectrum albedo{0.0};
};

// What a path is traced through: the scene, its lights, and how its hits are shaded.
struct PathTracer {
  const Scene& scene;
  const LightSet& lights;
  const Shading& shading;
  int max_depth = 64;  // bounces: 0 shows emitters and the environment only
};

// Radiance arriving at ray.origin along -ray.direction, estimated by one path. path: the path's
// shading state (Shading::start_path); first_hit: null, or filled for the AOVs. In the spectral
// mode (path.wavelengths()) the radiance and the first hit's albedo are at the path's three
// wavelengths (SampledWavelengths::radiance_to_rgb makes them colours).
Spectrum path_radiance(const PathTracer& tracer, Ray ray, Rng& rng, PathShading& path, RayCounters* rays,
                       FirstHit* first_hit = nullptr);

}  // namespace lamina
