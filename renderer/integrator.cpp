#include "renderer/integrator.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "renderer/surface.h"

namespace lamina {
namespace {

// Power heuristic with beta = 2 (Veach 1997, eq. 9.13), for one sample of each strategy.
double power_heuristic(double pdf_a, double pdf_b) {
  const double a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return a + b > 0.0 ? a / (a + b) : 0.0;
}

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

}  // namespace

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
                       RayCounters* rays) {
  const SceneDesc& desc = scene.desc();
  Spectrum radiance(0.0), beta(1.0);
  bool unweighted = true;  // camera ray, or the last bounce was a delta lobe
  double bsdf_pdf = 0.0;   // density of the last BSDF sample
  for (int depth = 0;; ++depth) {
    SurfaceHit hit;
    if (!scene.intersect(ray, &hit, rays)) {
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
    if (glm::dot(ng, wo_world) < 0.0) {
      ng = -ng;
      ns = -ns;
    }
    // A shading normal that puts the viewer below the surface is unusable here: use ng.
    if (glm::dot(ns, wo_world) <= 0.0) ns = ng;
    const Frame frame(ns);
    const glm::dvec3 wo = frame.to_local(wo_world);

    const Material& mat = desc.material(desc.meshes[hit.mesh].material);
    Spectrum albedo = mat.base_color;
    if (mat.base_color_texture >= 0) albedo *= desc.textures[mat.base_color_texture].lookup(hit.uv);
    const LambertSurface lambert(albedo);
    const Surface& surface = lambert;

    // Next-event estimation: one light chosen by power, one point on it.
    if (!lights.empty() && !surface.is_delta()) {
      double pmf = 0.0;
      const Light* light = lights.choose(rng.uniform(), &pmf);
      const glm::dvec2 u(rng.uniform(), rng.uniform());
      LightSample ls;
      if (pmf > 0.0 && light->sample_li(hit.p, u, &ls)) {
        const glm::dvec3 wi = frame.to_local(ls.wi);
        const double cos_g = glm::dot(ls.wi, ng);
        // The shading and geometric normals must agree on the side of wi, or light leaks.
        const Spectrum f = (cos_g * wi.z > 0.0) ? surface.eval(wo, wi) * std::abs(wi.z) : Spectrum(0.0);
        if (!f.is_black()) {
          Ray shadow{offset_ray_origin(hit.p, cos_g > 0.0 ? ng : -ng), ls.wi};
          double tmax = 1e300;
          if (!ls.infinite) {
            const glm::dvec3 v = ls.target - shadow.origin;
            const double dist = glm::length(v);
            shadow.direction = v / dist;
            tmax = dist * (1.0 - 1e-6);  // stop short of the (offset) point on the light
          }
          if (!scene.occluded(shadow, tmax, rays)) {
            const double w = light->is_delta() ? 1.0 : power_heuristic(pmf * ls.pdf, surface.pdf(wo, wi));
            radiance += beta * f * ls.li * (w / (pmf * ls.pdf));
          }
        }
      }
    }

    // Continue the path by sampling the BSDF.
    BsdfSample bs;
    if (!surface.sample(wo, glm::dvec2(rng.uniform(), rng.uniform()), &bs)) break;
    const glm::dvec3 wi_world = frame.to_world(bs.wi);
    const double cos_g = glm::dot(wi_world, ng);
    if (!(cos_g * bs.wi.z > 0.0)) break;  // leaks through the geometric surface: no light
    beta *= bs.f * (std::abs(bs.wi.z) / bs.pdf);
    unweighted = bs.delta;
    bsdf_pdf = bs.pdf;
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
  std::atomic<std::uint64_t> closest{0}, camera_rays{0}, shadow{0}, invalid{0};

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
          const Spectrum l = path_radiance(scene, lights, ray, rng, s.max_depth, &rays);
          if (l.is_finite()) sum += l;
          else ++bad;
        }
        float* p = image.pixel(x, y);
        for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(sum[c] / s.spp);
      }
    closest += rays.closest;
    camera_rays += rays.camera;
    shadow += rays.shadow;
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
    stats->invalid_samples = invalid;
  }
  return image;
}

}  // namespace lamina
