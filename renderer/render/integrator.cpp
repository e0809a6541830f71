#include "renderer/render/integrator.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "materials/random_walk.h"
#include "renderer/surfaces/first_order_surface.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "renderer/surfaces/table_surface.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/surfaces/surface.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/subsurface_mode.h"

namespace lamina {
namespace {

// Local shading frame around n: to_local(v) = (v.t, v.b, v.n).
struct Frame {
  glm::dvec3 t, b, n;
  explicit Frame(const glm::dvec3& normal) : n(normal) { orthonormal_basis(n, &t, &b); }
  glm::dvec3 to_local(const glm::dvec3& v) const { return {glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)}; }
  glm::dvec3 to_world(const glm::dvec3& v) const { return v.x * t + v.y * b + v.z * n; }
};

// Weight of emission found by a BSDF-sampled ray: 1 for camera rays and after delta
// scattering (light sampling could not have found it), else the MIS weight against the
// density with which next-event estimation would have chosen the same direction.
double emission_weight(const LightSet& lights, const Light* light, bool unweighted, double bsdf_pdf,
                       const glm::dvec3& from, const glm::dvec3& dir, const SurfaceHit* hit) {
  if (unweighted || !light) return 1.0;
  const double light_pdf = lights.pmf(light) * light->pdf_li(from, dir, hit);
  return power_heuristic(bsdf_pdf, light_pdf);
}

// Light samples of the pool drawn one at a time for the events of a layered walk
// (LightSampler), each with its own shadow ray.
class PoolSampler final : public LightSampler {
 public:
  PoolSampler(const Scene& scene, const LightSet& lights, const glm::dvec3& p, const glm::dvec3& ng,
              const Frame& frame, const Spectrum& beta, Spectrum* radiance, RayCounters* rays)
      : scene_(scene), lights_(lights), p_(p), ng_(ng), frame_(frame), beta_(beta), radiance_(radiance), rays_(rays) {}

  bool draw(Rng& rng, LightDirection* light) override {
    const Light* chosen = lights_.choose(rng.uniform(), &pmf_);
    const glm::dvec2 u(rng.uniform(), rng.uniform());
    if (!chosen || !(pmf_ > 0.0) || !chosen->sample_li(p_, u, &sample_)) return false;
    const glm::dvec3 wi = frame_.to_local(sample_.wi);
    if (!(glm::dot(sample_.wi, ng_) * wi.z > 0.0)) return false;
    *light = LightDirection{wi, pmf_ * sample_.pdf, chosen->is_delta(), Spectrum(0.0)};
    return true;
  }
  void add(const Spectrum& f_cos) override {
    if (visible(scene_, p_, ng_, sample_, rays_)) *radiance_ += beta_ * f_cos * sample_.li / (pmf_ * sample_.pdf);
  }

  // True if nothing blocks the segment from p (offset off the surface on the light's side) to
  // the light sample.
  static bool visible(const Scene& scene, const glm::dvec3& p, const glm::dvec3& ng, const LightSample& ls,
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

 private:
  const Scene& scene_;
  const LightSet& lights_;
  const glm::dvec3& p_;
  const glm::dvec3& ng_;
  const Frame& frame_;
  const Spectrum& beta_;
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
    LightSample& ls = sample[count];
    if (!(pmf_light > 0.0) || !light->sample_li(p, u, &ls)) return;
    const glm::dvec3 wi = frame.to_local(ls.wi);
    // The shading and geometric normals must agree on the side of wi, or light leaks.
    if (!(glm::dot(ls.wi, ng) * wi.z > 0.0)) return;
    pmf[count] = pmf_light;
    direction[count] = LightDirection{wi, pmf_light * ls.pdf, light->is_delta(), Spectrum(0.0)};
    ++count;
  }
};

}  // namespace

// Stratified hero channel (one-sample MIS made multi-sample over a pixel's samples).
//
// The walk's weights (random_walk.cpp, "Spectral MIS") are the one-sample balance heuristic: a
// hero h drawn with probability 1/3, weight W_c = f_c / ((1/3) sum_k p_k). E[W_c] = integral f_c
// needs only that h be uniform MARGINALLY and independent of the rest of the walk's randomness;
// nothing requires the heroes of different walks to be independent. Here the k-th walk of
// sample i of a pixel uses h = (i + o_k) mod 3 with o_k uniform on {0, 1, 2} from a stream of its
// own, keyed by (seed, pixel, k) and never by thread:
//  * marginally, P(h = c) = P(o_k = (c - i) mod 3) = 1/3 for every i, and o_k is independent of
//    sample i's stream (and so of the path before the walk, which decides whether there is a k-th
//    walk at all): each sample is the unbiased one-sample estimator, so the pixel mean is
//    unbiased for ANY spp, multiple of 3 or not;
//  * over samples 3m, 3m+1, 3m+2 every channel is the hero of the k-th walk exactly once. For
//    the first walk (same pixel, nearly the same entry point and direction) three such samples
//    are the multi-sample MIS estimator with one sample per technique and balance-heuristic
//    weights (Veach 1997, section 9.2: sum_c w_c(X_c) f(X_c) / p_c(X_c) with
//    w_c = p_c / sum_k p_k, i.e. sum_c f(X_c) / sum_k p_k(X_c), which is the mean of the three
//    samples' one-sample weights 3 f / sum_k p_k). The number of walks per hero in a pixel is
//    no longer multinomial, which removes the chroma noise that came from one channel being the
//    hero more often than the others. Later walks (k > 0) start from diverged paths and gain
//    less (their offsets are still stratified per walk index).
// Light samples at events need no change: connection_weight and the event's throughput are
// conditional on the walk's hero, and exit_pdf_for_mis is the mean over the three heroes, which
// does not depend on how the hero was chosen (materials/walk_estimator.h, exit_pdf_for_mis).
int HeroStrata::hero(int walk_index) const {
  Rng offset_rng(seed, pixel, kHeroStream + static_cast<std::uint64_t>(walk_index));
  const int offset = std::min(kChannels - 1, static_cast<int>(offset_rng.uniform() * kChannels));
  return static_cast<int>((sample + static_cast<std::uint64_t>(offset)) % kChannels);
}

glm::dvec2 sample_tent_filter(glm::dvec2 u) {
  // Inverse CDF of the tent f(x) = 1 - |x| on [-1, 1]: x = sqrt(2u) - 1 for u < 1/2,
  // 1 - sqrt(2 - 2u) otherwise.
  // One square root and selects rather than branches: the branch on a random u mispredicts
  // half the time, twice per camera ray.
  auto tent = [](double v) {
    const bool low = v < 0.5;
    const double s = std::sqrt(low ? 2.0 * v : 2.0 - 2.0 * v);
    return low ? s - 1.0 : 1.0 - s;
  };
  return {tent(u.x), tent(u.y)};
}

Spectrum path_radiance(const Scene& scene, const LightSet& lights, Ray ray, Rng& rng, int max_depth,
                       RayCounters* rays, const LayeredShading* layered, const HeroStrata* strata) {
  const SceneDesc& desc = scene.desc();
  thread_local StackScratch scratch;  // stack_at() may build a stack per hit here
  Spectrum radiance(0.0), beta(1.0);
  bool unweighted = true;  // camera ray, or the last bounce was a delta lobe
  double bsdf_pdf = 0.0;   // density of the last BSDF sample
  int walks = 0;           // random walks run so far on this path (index of the next one)
  for (int depth = 0;; ++depth) {
    SurfaceHit hit;
    if (!scene.intersect(ray, &hit, *rays)) {
      if (const Light* env = lights.environment())
        radiance += beta * lights.environment_map().eval(ray.direction) *
                    emission_weight(lights, env, unweighted, bsdf_pdf, ray.origin, ray.direction, nullptr);
      break;
    }
    const glm::dvec3 wo_world = -ray.direction;
    const Spectrum le = emitted_radiance(scene, hit, wo_world);
    if (!le.is_black())
      radiance += beta * le *
                  emission_weight(lights, lights.triangle_light(hit.mesh, hit.triangle), unweighted, bsdf_pdf,
                                  ray.origin, ray.direction, &hit);
    if (depth >= max_depth) break;

    // Shade both sides of every surface: turn the normals towards the viewer.
    glm::dvec3 ng = hit.ng, ns = hit.ns;
    const bool back_side = glm::dot(ng, wo_world) < 0.0;
    if (back_side) {
      ng = -ng;
      ns = -ns;
    }
    // A shading normal that puts the viewer below the surface is unusable here: use ng.
    if (glm::dot(ns, wo_world) <= 0.0) ns = ng;
    const Frame frame(ns);
    const glm::dvec3 wo = frame.to_local(wo_world);

    const int material_index = desc.meshes[hit.mesh].material;
    const Material& mat = desc.material(material_index);
    const LayeredMaterial* lm = layered && layered->bindings ? layered->bindings->get(material_index) : nullptr;
    const SubsurfaceMode mode = lm ? layered->mode_for(material_index) : SubsurfaceMode::RandomWalk;
    Spectrum albedo = mat.base_color;
    if (lm && mode == SubsurfaceMode::Lambert) albedo = lm->lambert_albedo();
    else if (mat.base_color_texture >= 0) albedo *= desc.textures[mat.base_color_texture].lookup(hit.uv);
    const LambertSurface lambert(albedo);
    const Surface* surface_ptr = &lambert;
    std::optional<FirstOrderSurface> first_order;
    std::optional<TableSurface> table;
    const LayerStack* stack = nullptr;
    if (lm && mode != SubsurfaceMode::Lambert) {
      // The top faces the viewer: a transmitting stack seen from behind is flipped; any other
      // stack is seen from its top from either side (closed meshes).
      ShadingPoint sp;
      sp.p = hit.p;
      sp.uv = hit.uv;
      sp.mesh = hit.mesh;
      sp.triangle = hit.triangle;
      sp.from_below = back_side && lm->transmits();
      stack = &lm->stack_at(sp, scratch);
      if (mode == SubsurfaceMode::FirstOrder) {
        first_order.emplace(*stack, wo);
        surface_ptr = &*first_order;
      } else if (mode == SubsurfaceMode::Table) {
        table.emplace(layered->tables->get(lm, sp.from_below), wo);
        surface_ptr = &*table;
      }
    }

    std::optional<RandomWalkSurface> walk;
    if (stack && mode == SubsurfaceMode::RandomWalk) {
      const int hero = strata && layered->stratified_hero ? strata->hero(walks) : kRandomHero;
      ++walks;
      walk.emplace(*stack, hero,
                   RandomWalkOptions{layered->naive, layered->connections_only, layered->per_event_pool_samples,
                                     layered->similarity_after},
                   &rays->scatter_events);
      surface_ptr = &*walk;
    }
    const Surface& surface = *surface_ptr;

    // Next-event estimation: every delta light, and one light of the pool chosen by power; the
    // surface connects to all of them (a layered walk from every one of its events), then one
    // shadow ray per direction it lights. A surface that draws per event (a layered walk, by
    // default) gets the pool through a LightSampler instead.
    LightSamples nee;
    const bool per_event = surface.draws_per_event() && !lights.pool_empty();
    PoolSampler pool(scene, lights, hit.p, ng, frame, beta, &radiance, rays);
    if (!lights.empty() && !surface.is_delta()) {
      for (const Light* light : lights.sampled_each()) nee.offer(light, 1.0, glm::dvec2(0.5), hit.p, ng, frame);
      double pmf = 0.0;
      if (!per_event && !lights.pool_empty())
        if (const Light* light = lights.choose(rng.uniform(), &pmf)) {
          const glm::dvec2 u(rng.uniform(), rng.uniform());
          nee.offer(light, pmf, u, hit.p, ng, frame);
        }
    }
    SurfaceScatter next;
    const bool continues =
        surface.scatter(wo, rng, nee.direction, nee.count, per_event ? &pool : nullptr, &next);
    for (int k = 0; k < nee.count; ++k) {
      const Spectrum& f_cos = nee.direction[k].f_cos;
      if (!f_cos.is_black() && PoolSampler::visible(scene, hit.p, ng, nee.sample[k], rays))
        radiance += beta * f_cos * nee.sample[k].li / (nee.pmf[k] * nee.sample[k].pdf);
    }

    // Continue the path as the surface chose.
    if (!continues) break;
    const glm::dvec3 wi_world = frame.to_world(next.wi);
    const double cos_g = glm::dot(wi_world, ng);
    if (!(cos_g * next.wi.z > 0.0)) break;  // leaks through the geometric surface: no light
    beta *= next.weight;
    unweighted = next.delta;
    bsdf_pdf = next.pdf;
    ray = Ray{offset_ray_origin(hit.p, cos_g > 0.0 ? ng : -ng), wi_world};

    // Russian roulette after three bounces: continue with probability min(1, max beta) and
    // divide by it, which keeps the estimate unbiased (pbrt-v4 14.1.6, without the eta term).
    if (depth >= 2) {
      const double q = std::max(0.0, 1.0 - beta.max());
      if (rng.uniform() < q) break;
      beta /= 1.0 - q;
    }
  }
  return radiance;
}

Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
                   RenderStats* stats, const std::function<void(std::uint64_t)>& on_progress) {
  Image image(s.width, s.height);
  constexpr int kTile = 16;
  const int tiles_x = (s.width + kTile - 1) / kTile, tiles_y = (s.height + kTile - 1) / kTile;
  std::atomic<std::uint64_t> closest{0}, camera_rays{0}, shadow{0}, invalid{0}, events{0};

  auto render_tile = [&](int tile) {
    const int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
    const int x1 = std::min(x0 + kTile, s.width), y1 = std::min(y0 + kTile, s.height);
    RayCounters rays;
    rays.log = s.ray_log;
    std::uint64_t bad = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const std::uint64_t pixel = static_cast<std::uint64_t>(y) * s.width + x;
        Spectrum sum(0.0);
        for (int i = 0; i < s.spp; ++i) {
          Rng rng(s.seed, pixel, static_cast<std::uint64_t>(i));
          const glm::dvec2 d = sample_tent_filter({rng.uniform(), rng.uniform()});
          const Ray ray = camera.generate_ray({x + 0.5 + d.x, y + 0.5 + d.y});
          ++rays.camera;
          const HeroStrata strata{s.seed, pixel, static_cast<std::uint64_t>(i)};
          const Spectrum l = path_radiance(scene, lights, ray, rng, s.max_depth, &rays, s.layered, &strata);
          if (l.is_finite()) sum += l;
          else ++bad;
        }
        float* p = image.pixel(x, y);
        for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(sum[c] / s.spp);
      }
    closest += rays.closest;
    camera_rays += rays.camera;
    shadow += rays.shadow;
    events += rays.scatter_events;
    invalid += bad;
    if (on_progress) on_progress(static_cast<std::uint64_t>(x1 - x0) * (y1 - y0) * s.spp);
  };

  tbb::task_arena arena(s.ray_log ? 1 : s.threads > 0 ? s.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y, 1), [&](const tbb::blocked_range<int>& r) {
      for (int t = r.begin(); t != r.end(); ++t) render_tile(t);
    });
  });
  if (stats) {
    stats->rays.closest = closest;
    stats->rays.camera = camera_rays;
    stats->rays.shadow = shadow;
    stats->rays.scatter_events = events;
    stats->invalid_samples = invalid;
  }
  return image;
}

}  // namespace lamina
