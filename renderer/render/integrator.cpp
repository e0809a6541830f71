#include "renderer/render/integrator.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "renderer/surfaces/frame.h"
#include "renderer/surfaces/surface.h"
#include "renderer/surfaces/surface_storage.h"

namespace lamina {
namespace {

// Weight of emission found by a BSDF-sampled ray: 1 for camera rays and after delta
// scattering (light sampling could not have found it), else the MIS weight against the
// density with which next-event estimation would have chosen the same direction.
double emission_weight(const LightSet& lights, const Light* light, bool unweighted, double bsdf_pdf,
                       const glm::dvec3& from, const glm::dvec3& dir, const SurfaceHit* hit) {
  if (unweighted || !light) return 1.0;
  const double light_pdf = lights.pmf(light) * light->pdf_li(from, dir, hit);
  return power_heuristic(bsdf_pdf, light_pdf);
}

// Samples `light` (chosen with probability pmf) from p as a direction in the shading frame;
// false if it gives no light, or if the shading and geometric normals disagree on the side of
// its direction (light would leak through the surface).
bool sample_light_direction(const Light& light, double pmf, glm::dvec2 u, const glm::dvec3& p, const glm::dvec3& ng,
                            const Frame& frame, LightSample* ls, LightDirection* direction) {
  if (!(pmf > 0.0) || !light.sample_li(p, u, ls)) return false;
  const glm::dvec3 wi = frame.to_local(ls->wi);
  if (!(glm::dot(ls->wi, ng) * wi.z > 0.0)) return false;
  *direction = LightDirection{wi, pmf * ls->pdf, light.is_delta(), Spectrum(0.0)};
  return true;
}

// True if nothing blocks the segment from p (offset off the surface on the light's side) to the
// light sample.
bool light_visible(const Scene& scene, const glm::dvec3& p, const glm::dvec3& ng, const LightSample& ls,
                   RayCounters* rays) {
  Ray shadow{offset_ray_origin(p, glm::dot(ls.wi, ng) > 0.0 ? ng : -ng), ls.wi};
  double tmax = 1e300;
  if (!ls.infinite) {
    const glm::dvec3 v = ls.target - shadow.origin;
    const double dist = glm::length(v);
    shadow.direction = v / dist;
    tmax = dist * (1.0 - 1e-6);  // stop short of the (offset) point on the light
  }
  return !scene.occluded(shadow, tmax, *rays);
}

// The radiance of an emitter (a light, an emissive surface, the environment: all given in RGB)
// as the path carries it: unchanged in the RGB mode, at the path's wavelengths in the spectral
// mode (SampledWavelengths::illuminant).
Spectrum emitted(const SampledWavelengths* wavelengths, const Spectrum& rgb) {
  return wavelengths ? wavelengths->illuminant(rgb) : rgb;
}

// Light samples of the pool drawn one at a time for the events of a layered walk
// (LightSampler), each with its own shadow ray.
class PoolSampler final : public LightSampler {
 public:
  PoolSampler(const Scene& scene, const LightSet& lights, const glm::dvec3& p, const glm::dvec3& ng,
              const Frame& frame, const Spectrum& beta, const SampledWavelengths* wavelengths, Spectrum* radiance,
              RayCounters* rays)
      : scene_(scene), lights_(lights), p_(p), ng_(ng), frame_(frame), beta_(beta), wavelengths_(wavelengths),
        radiance_(radiance), rays_(rays) {}

  bool draw(Rng& rng, LightDirection* light) override {
    const Light* chosen = lights_.choose(rng.uniform(), &pmf_);
    const glm::dvec2 u(rng.uniform(), rng.uniform());
    return chosen && sample_light_direction(*chosen, pmf_, u, p_, ng_, frame_, &sample_, light);
  }
  void add(const Spectrum& f_cos) override {
    if (light_visible(scene_, p_, ng_, sample_, rays_))
      *radiance_ += beta_ * f_cos * emitted(wavelengths_, sample_.li) / (pmf_ * sample_.pdf);
  }

 private:
  const Scene& scene_;
  const LightSet& lights_;
  const glm::dvec3& p_;
  const glm::dvec3& ng_;
  const Frame& frame_;
  const Spectrum& beta_;
  const SampledWavelengths* wavelengths_;
  Spectrum* radiance_;
  RayCounters* rays_;
  LightSample sample_;
  double pmf_ = 0.0;
};

// The light samples of next-event estimation at one shading point (LightSet: every delta light,
// and one sample of the pool), as directions offered to the surface.
struct LightSamples {
  static constexpr int kMax = static_cast<int>(LightSet::kMaxLightsSampledEach) + 1;
  int count = 0;
  LightSample sample[kMax];
  double pmf[kMax];
  LightDirection direction[kMax];

  void offer(const Light* light, double pmf_light, glm::dvec2 u, const glm::dvec3& p, const glm::dvec3& ng,
             const Frame& frame) {
    if (!sample_light_direction(*light, pmf_light, u, p, ng, frame, &sample[count], &direction[count])) return;
    pmf[count] = pmf_light;
    ++count;
  }
};

// What a path carries from bounce to bounce.
struct PathState {
  Spectrum radiance{0.0}, beta{1.0};
  bool unweighted = true;  // camera ray, or the last bounce was a delta lobe
  double bsdf_pdf = 0.0;   // density of the last BSDF sample
  const SampledWavelengths* wavelengths = nullptr;  // the spectral mode's (PathShading::wavelengths)
};

// The environment's light, found by a ray that leaves the scene.
void add_environment(const LightSet& lights, const Ray& ray, PathState* path) {
  if (const Light* env = lights.environment())
    path->radiance += path->beta * emitted(path->wavelengths, lights.environment_map().eval(ray.direction)) *
                      emission_weight(lights, env, path->unweighted, path->bsdf_pdf, ray.origin, ray.direction, nullptr);
}

// The light emitted by the surface the ray hit, towards the ray's origin.
void add_emission(const Scene& scene, const LightSet& lights, const SurfaceHit& hit, const Ray& ray, PathState* path) {
  const Spectrum le = emitted_radiance(scene, hit, -ray.direction);
  if (!le.is_black())
    path->radiance += path->beta * emitted(path->wavelengths, le) *
                      emission_weight(lights, lights.triangle_light(hit.mesh, hit.triangle), path->unweighted,
                                      path->bsdf_pdf, ray.origin, ray.direction, &hit);
}

// Next-event estimation's light samples: every delta light, and one light of the pool chosen by
// power (unless the surface draws the pool per event); none for a purely delta surface.
void draw_light_samples(const LightSet& lights, const Surface& surface, bool per_event, const glm::dvec3& p,
                        const ShadingGeometry& g, Rng& rng, LightSamples* nee) {
  if (lights.empty() || surface.is_delta()) return;
  for (const Light* light : lights.sampled_each()) nee->offer(light, 1.0, glm::dvec2(0.5), p, g.ng, g.frame);
  double pmf = 0.0;
  if (!per_event && !lights.pool_empty())
    if (const Light* light = lights.choose(rng.uniform(), &pmf)) {
      const glm::dvec2 u(rng.uniform(), rng.uniform());
      nee->offer(light, pmf, u, p, g.ng, g.frame);
    }
}

// One shadow ray per light direction the surface's connections lit.
void add_light_connections(const Scene& scene, const LightSamples& nee, const glm::dvec3& p, const glm::dvec3& ng,
                           RayCounters* rays, PathState* path) {
  for (int k = 0; k < nee.count; ++k) {
    const Spectrum& f_cos = nee.direction[k].f_cos;
    if (!f_cos.is_black() && light_visible(scene, p, ng, nee.sample[k], rays))
      path->radiance += path->beta * f_cos * emitted(path->wavelengths, nee.sample[k].li) / (nee.pmf[k] * nee.sample[k].pdf);
  }
}

// Continues the path as the surface chose: the next ray and the path's throughput. False if the
// direction leaks through the geometric surface (no light).
bool continue_path(const SurfaceScatter& next, const glm::dvec3& p, const ShadingGeometry& g, FirstHit* first_hit,
                   Ray* ray, PathState* path) {
  const glm::dvec3 wi_world = g.frame.to_world(next.wi);
  const double cos_g = glm::dot(wi_world, g.ng);
  if (!(cos_g * next.wi.z > 0.0)) return false;
  if (first_hit) first_hit->albedo = next.weight;
  path->beta *= next.weight;
  path->unweighted = next.delta;
  path->bsdf_pdf = next.pdf;
  *ray = Ray{offset_ray_origin(p, cos_g > 0.0 ? g.ng : -g.ng), wi_world};
  return true;
}

// Russian roulette: continue with probability min(1, max beta) and divide by it, which keeps the
// estimate unbiased (pbrt-v4 14.1.6, without the eta term).
bool survives_roulette(Rng& rng, Spectrum* beta) {
  const double q = std::max(0.0, 1.0 - beta->max());
  if (rng.uniform() < q) return false;
  *beta /= 1.0 - q;
  return true;
}

void record_first_hit(const SurfaceHit& hit, const Ray& ray, const ShadingGeometry& g, FirstHit* first_hit) {
  first_hit->hit = true;
  first_hit->distance = hit.t * glm::length(ray.direction);
  first_hit->normal = g.frame.n;
}

}  // namespace

Spectrum path_radiance(const PathTracer& tracer, Ray ray, Rng& rng, PathShading& shading_state, RayCounters* rays,
                       FirstHit* first_hit) {
  const Scene& scene = tracer.scene;
  const LightSet& lights = tracer.lights;
  PathState path;
  path.wavelengths = shading_state.wavelengths();
  for (int depth = 0;; ++depth) {
    SurfaceHit hit;
    if (!scene.intersect(ray, &hit, *rays)) {
      add_environment(lights, ray, &path);
      break;
    }
    add_emission(scene, lights, hit, ray, &path);
    if (depth >= tracer.max_depth) break;

    SurfaceStorage storage;
    ShadingGeometry g;
    const Surface& surface = tracer.shading.surface_at(hit, -ray.direction, shading_state, storage, &g);
    FirstHit* first = depth == 0 ? first_hit : nullptr;
    if (first) record_first_hit(hit, ray, g, first);

    // Next-event estimation: the surface connects to every light direction (a layered walk from
    // every one of its events), then one shadow ray per direction it lights. A surface that
    // draws per event (a layered walk with --pool-samples per-event) gets the pool through a
    // LightSampler instead.
    LightSamples nee;
    const bool per_event = surface.draws_per_event() && !lights.pool_empty();
    draw_light_samples(lights, surface, per_event, hit.p, g, rng, &nee);
    PoolSampler pool(scene, lights, hit.p, g.ng, g.frame, path.beta, path.wavelengths, &path.radiance, rays);
    SurfaceScatter next;
    const bool continues = surface.scatter(g.wo, rng, nee.direction, nee.count, per_event ? &pool : nullptr, &next);
    add_light_connections(scene, nee, hit.p, g.ng, rays, &path);

    if (!continues || !continue_path(next, hit.p, g, first, &ray, &path)) break;
    // Russian roulette after three bounces.
    if (depth >= 2 && !survives_roulette(rng, &path.beta)) break;
  }
  return path.radiance;
}

}  // namespace lamina
