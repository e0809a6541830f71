#include "renderer/render/integrator.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "materials/walk/random_walk.h"
#include "renderer/surfaces/first_order_surface.h"
#include "renderer/surfaces/metallic_roughness_surface.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "renderer/surfaces/table_surface.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/stack_bindings.h"
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
    return chosen && sample_light_direction(*chosen, pmf_, u, p_, ng_, frame_, &sample_, light);
  }
  void add(const Spectrum& f_cos) override {
    if (light_visible(scene_, p_, ng_, sample_, rays_)) *radiance_ += beta_ * f_cos * sample_.li / (pmf_ * sample_.pdf);
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
    if (!sample_light_direction(*light, pmf_light, u, p, ng, frame, &sample[count], &direction[count])) return;
    pmf[count] = pmf_light;
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
// does not depend on how the hero was chosen (materials/walk/walk_estimator.h, exit_pdf_for_mis).
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
                       RayCounters* rays, const LayeredShading* layered, const HeroStrata* strata, FirstHit* first_hit) {
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
    const int material_index = desc.meshes[hit.mesh].material;
    const Material& mat = desc.material(material_index);
    glm::dvec3 ng = hit.ng, ns = hit.ns;
    if (mat.normal_texture >= 0 && hit.tangent != glm::dvec4(0.0))
      ns = normal_mapped(hit, desc.textures[mat.normal_texture], mat.normal_scale, mat.normal_uv.apply(hit.uv));
    const bool back_side = glm::dot(ng, wo_world) < 0.0;
    if (back_side) {
      ng = -ng;
      ns = -ns;
    }
    // A shading normal that puts the viewer below the surface is unusable here: use ng.
    if (glm::dot(ns, wo_world) <= 0.0) ns = ng;
    const Frame frame(ns);
    const glm::dvec3 wo = frame.to_local(wo_world);
    if (depth == 0 && first_hit) {
      first_hit->hit = true;
      first_hit->distance = hit.t * glm::length(ray.direction);
      first_hit->normal = ns;
    }

    const LayeredMaterial* lm = layered && layered->bindings ? layered->bindings->get(material_index) : nullptr;
    const SubsurfaceMode mode = lm ? layered->mode_for(material_index) : SubsurfaceMode::RandomWalk;
    Spectrum albedo = mat.base_color;
    if (lm && mode == SubsurfaceMode::Lambert) albedo = lm->lambert_albedo_at(hit.uv);
    else if (mat.base_color_texture >= 0) albedo *= desc.textures[mat.base_color_texture].lookup(mat.base_color_uv.apply(hit.uv));
    if (!(lm && mode == SubsurfaceMode::Lambert)) albedo *= Spectrum(hit.colour.x, hit.colour.y, hit.colour.z);
    const LambertSurface lambert(albedo);
    const Surface* surface_ptr = &lambert;
    // A glTF material that is not layered: its metallic-roughness BRDF (Appendix B), with the
    // metallicRoughnessTexture's B (metalness) and G (roughness) multiplied in.
    std::optional<MetallicRoughnessSurface> metallic_roughness;
    if (!lm && mat.metallic_roughness) {
      double metallic = mat.metallic, roughness = mat.roughness;
      if (mat.metallic_roughness_texture >= 0) {
        const Spectrum t = desc.textures[mat.metallic_roughness_texture].lookup(mat.metallic_roughness_uv.apply(hit.uv));
        roughness *= t[1];
        metallic *= t[2];
      }
      metallic_roughness.emplace(albedo, metallic, roughness);
      surface_ptr = &*metallic_roughness;
    }
    std::optional<FirstOrderSurface> first_order;
    std::optional<TableSurface> table;
    TableFactor table_factors[LayeredTables::kMaxFactors];  // the table's, while it lives
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
        // Texture-driven parameters scale the table's bins (renderer/layered/layered_tables.h).
        int factor_count = 0;
        if (const StackBindings* b = lm->bindings(); b && !b->empty()) {
          ParameterValues values(b->parameters().size());
          b->values(hit.uv, values.data());
          factor_count = layered->tables->factors(lm, sp.from_below, values.data(), table_factors);
        }
        table.emplace(layered->tables->get(lm, sp.from_below), *stack, wo, table_factors, factor_count);
        surface_ptr = &*table;
      }
    }

    std::optional<RandomWalkSurface> walk;
    if (stack && mode == SubsurfaceMode::RandomWalk) {
      const int hero = strata && layered->stratified_hero ? strata->hero(walks) : kRandomHero;
      ++walks;
      walk.emplace(*stack, hero, layered->walk, &rays->scatter_events);
      surface_ptr = &*walk;
    }
    const Surface& surface = *surface_ptr;

    // Next-event estimation: every delta light, and one light of the pool chosen by power; the
    // surface connects to all of them (a layered walk from every one of its events), then one
    // shadow ray per direction it lights. A surface that draws per event (a layered walk with
    // --pool-samples per-event) gets the pool through a LightSampler instead.
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
      if (!f_cos.is_black() && light_visible(scene, hit.p, ng, nee.sample[k], rays))
        radiance += beta * f_cos * nee.sample[k].li / (nee.pmf[k] * nee.sample[k].pdf);
    }

    // Continue the path as the surface chose.
    if (!continues) break;
    const glm::dvec3 wi_world = frame.to_world(next.wi);
    const double cos_g = glm::dot(wi_world, ng);
    if (!(cos_g * next.wi.z > 0.0)) break;  // leaks through the geometric surface: no light
    if (depth == 0 && first_hit) first_hit->albedo = next.weight;
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

// Adaptive sampling, unbiased by construction. A pilot pass renders the first `pilot_spp`
// samples of every pixel and keeps, per pixel, the mean m_q and variance v_q of their luminance.
// Pixel p is then planned from its NEIGHBOURS (the up to 8 pixels around it, not p itself):
//     N_p = clamp(ceil(v / (E^2 m^2)), pilot_spp, spp),  m, v the means of m_q, v_q over them,
// enough for a relative standard error E of p's mean if p's noise is like theirs. Since N_p does
// not depend on p's own samples (pixels' samples are independent streams), p's image value, the
// mean of its N_p samples (the pilot's included), is unbiased whatever N_p is. (The usual scheme,
// stopping a pixel when its own running estimate looks converged, is biased: a heavy-tailed pixel
// that has not yet drawn its rare large sample looks converged early and stays dark.) Pooling 8
// neighbours also estimates v from 8x the samples, which matters for the heavy tails of layered
// walks. A pixel without neighbours (a 1x1 image) gets spp; one whose neighbours are all black in
// the pilot gets pilot_spp.
// Rounds: the planned samples are rendered in rounds of kRoundSamples per pixel over the whole
// image (sample indices in increasing order, so a pixel's sum is the same as in one pass: the
// image does not depend on the thread count, nor on the rounds). A time limit is checked before
// each tile of every round after the first; the count of each pixel's samples goes to
// RenderStats::pixel_samples (an EXR channel).
// Crop: only the region's pixels are rendered, with the random streams of their place in the
// full image; the pilot pass also covers a one-pixel margin around the region (clamped to the
// image), so every pixel of the region is planned from the same neighbours as in the full image.
namespace {

constexpr int kRoundSamples = 8;
// Tiles are the unit of parallel work. A pass ends when its last tile does, so a worker that
// finishes early idles for up to one tile's time: with few large tiles over a small image (a
// layered head at 80x100 in 16x16 tiles is 35 tiles, a dozen of them expensive) that tail was
// 7 % of the wall time on 2 threads. The side is halved from kMaxTile (down to kMinTile) until
// there are kTilesPerWorker tiles per worker; the image does not depend on it (every sample has
// its own random stream, and a pixel's samples are summed in order).
constexpr int kMaxTile = 16, kMinTile = 4, kTilesPerWorker = 128;

struct TileCounters {
  std::atomic<std::uint64_t> closest{0}, camera{0}, shadow{0}, invalid{0}, events{0};
  void add(const RayCounters& rays, std::uint64_t bad) {
    closest += rays.closest;
    camera += rays.camera;
    shadow += rays.shadow;
    events += rays.scatter_events;
    invalid += bad;
  }
};

// The running sums of one pixel: its colour, and what the AOVs and the pilot pass need.
struct PixelSums {
  Spectrum sum{0.0}, sum2{0.0}, albedo{0.0};
  glm::dvec3 normal{0.0};
  double depth = 0.0;
  double y_sum = 0.0, y_sum2 = 0.0;  // luminance, for the adaptive pilot
  std::uint32_t count = 0;           // samples drawn (non-finite ones included, as 0)
  std::uint32_t hits = 0;            // samples whose camera ray met a surface
  std::uint32_t clamped = 0;         // samples scaled down by --clamp
};

// A rectangle of pixels with its tiles.
struct Tiled {
  PixelRegion r;
  int side = kMaxTile, tiles_x = 0, tiles = 0;
  Tiled(PixelRegion region, int workers) : r(region) {
    for (;; side /= 2) {
      tiles_x = (r.x1 - r.x0 + side - 1) / side;
      tiles = tiles_x * ((r.y1 - r.y0 + side - 1) / side);
      if (side <= kMinTile || tiles >= kTilesPerWorker * workers) break;
    }
  }
  int width() const { return r.x1 - r.x0; }
  std::size_t index(int x, int y) const { return static_cast<std::size_t>(y - r.y0) * width() + (x - r.x0); }
  std::size_t pixels() const { return static_cast<std::size_t>(width()) * (r.y1 - r.y0); }
};

}  // namespace

Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
                   RenderStats* stats, const std::function<void(std::uint64_t)>& on_progress) {
  RenderProgress progress;
  progress.advance = on_progress;
  return render_image(scene, lights, camera, s, stats, progress);
}

Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
                   RenderStats* stats, const RenderProgress& progress, RenderAovs* aovs) {
  const auto start = std::chrono::steady_clock::now();
  tbb::task_arena arena(s.ray_log ? 1 : s.threads > 0 ? s.threads : tbb::task_arena::automatic);
  arena.initialize();
  const int workers = arena.max_concurrency();
  const Tiled out(s.crop.empty() ? PixelRegion{0, 0, s.width, s.height} : s.crop, workers);
  const std::size_t pixels = out.pixels();
  const AovSelection want = aovs ? s.aovs : AovSelection{};
  const bool first_hits = want.albedo || want.normal || want.depth;
  TileCounters counters;

  // Samples [first, first + count) of pixel (x, y) of the full image, added to *acc.
  auto sample_pixel = [&](int x, int y, int first, int count, PixelSums* acc, RayCounters& rays, std::uint64_t* bad,
                          bool luminance) {
    const std::uint64_t pixel = static_cast<std::uint64_t>(y) * s.width + x;
    for (int i = first; i < first + count; ++i) {
      const std::uint64_t index = static_cast<std::uint64_t>(i);
      Rng rng(s.seed, pixel, index);
      const glm::dvec2 d = sample_tent_filter({rng.uniform(), rng.uniform()});
      const Ray ray = camera.generate_ray({x + 0.5 + d.x, y + 0.5 + d.y});
      ++rays.camera;
      const HeroStrata strata{s.seed, pixel, index};
      FirstHit hit;
      Spectrum l =
          path_radiance(scene, lights, ray, rng, s.max_depth, &rays, s.layered, &strata, first_hits ? &hit : nullptr);
      ++acc->count;
      if (!l.is_finite()) {
        ++*bad;
        continue;
      }
      if (s.clamp > 0.0 && l.max() > s.clamp) {
        l *= s.clamp / l.max();
        ++acc->clamped;
      }
      acc->sum += l;
      if (want.variance) acc->sum2 += l * l;
      if (hit.hit) {
        acc->albedo += hit.albedo;
        acc->normal += hit.normal;
        acc->depth += hit.distance;
        ++acc->hits;
      }
      if (luminance) {
        const double lum = 0.2126 * l[0] + 0.7152 * l[1] + 0.0722 * l[2];
        acc->y_sum += lum;
        acc->y_sum2 += lum * lum;
      }
    }
  };

  Image image(out.width(), out.r.y1 - out.r.y0);
  if (want.albedo) aovs->albedo = Image(image.width, image.height);
  if (want.normal) aovs->normal = Image(image.width, image.height);
  if (want.variance) aovs->variance = Image(image.width, image.height);
  if (want.depth) aovs->depth.assign(pixels, 0.0f);
  // The image's pixel i from its sums (and the AOVs'); a pixel with no samples is black.
  std::atomic<std::uint64_t> clamped_total{0};
  auto resolve = [&](std::size_t i, const PixelSums& acc, Image* target) {
    float* p = &target->rgb[i * 3];
    const double n = acc.count;
    for (int c = 0; c < 3; ++c) p[c] = acc.count > 0 ? static_cast<float>(acc.sum[c] / n) : 0.0f;
    if (target != &image || acc.count == 0) return;
    if (acc.clamped > 0) clamped_total += acc.clamped;
    for (int c = 0; c < 3; ++c) {
      if (want.albedo) aovs->albedo.rgb[i * 3 + c] = static_cast<float>(acc.albedo[c] / n);
      if (want.normal) aovs->normal.rgb[i * 3 + c] = static_cast<float>(acc.normal[c] / n);
      if (want.variance)  // of the mean: the unbiased sample variance over n
        aovs->variance.rgb[i * 3 + c] =
            acc.count > 1 ? static_cast<float>(std::max(0.0, acc.sum2[c] - acc.sum[c] * acc.sum[c] / n) / (n - 1.0) / n) : 0.0f;
    }
    if (want.depth) aovs->depth[i] = acc.hits > 0 ? static_cast<float>(acc.depth / acc.hits) : 0.0f;
  };

  // Runs body(x, y) for every pixel of every tile of `area`, in parallel; false from keep_going
  // skips the tiles not yet started. body returns the samples it rendered, for the progress.
  auto for_tiles = [&](const Tiled& area, const std::function<std::uint64_t(int, int, RayCounters&, std::uint64_t*)>& body,
                       const std::function<bool()>& keep_going) {
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<int>(0, area.tiles, 1), [&](const tbb::blocked_range<int>& range) {
        for (int tile = range.begin(); tile != range.end(); ++tile) {
          if (keep_going && !keep_going()) continue;
          const int x0 = area.r.x0 + (tile % area.tiles_x) * area.side, y0 = area.r.y0 + (tile / area.tiles_x) * area.side;
          const int x1 = std::min(x0 + area.side, area.r.x1), y1 = std::min(y0 + area.side, area.r.y1);
          RayCounters rays;
          rays.log = s.ray_log;
          std::uint64_t bad = 0, done = 0;
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) done += body(x, y, rays, &bad);
          counters.add(rays, bad);
          if (progress.advance) progress.advance(done);
        }
      });
    });
  };

  const bool adaptive = s.noise_threshold > 0.0;
  const bool rounds = adaptive || s.time_limit > 0.0 || (s.preview_every > 0.0 && progress.preview);
  if (!rounds) {
    // Every pixel its spp samples in one pass.
    for_tiles(
        out,
        [&](int x, int y, RayCounters& rays, std::uint64_t* bad) {
          PixelSums acc;
          sample_pixel(x, y, 0, s.spp, &acc, rays, bad, false);
          resolve(out.index(x, y), acc, &image);
          return static_cast<std::uint64_t>(s.spp);
        },
        {});
  } else {
    std::vector<std::uint32_t> planned(pixels, static_cast<std::uint32_t>(s.spp));
    double converged = 0.0;
    std::vector<PixelSums> sums(pixels);
    int first_round = 0;
    if (adaptive) {
      const int pilot = std::clamp(s.pilot_spp, 1, s.spp);
      // The region and a one-pixel margin (the neighbours of its edge pixels).
      const Tiled piloted(PixelRegion{std::max(out.r.x0 - 1, 0), std::max(out.r.y0 - 1, 0), std::min(out.r.x1 + 1, s.width),
                                      std::min(out.r.y1 + 1, s.height)}, workers);
      std::vector<double> pilot_mean(piloted.pixels()), pilot_var(piloted.pixels());
      for_tiles(
          piloted,
          [&](int x, int y, RayCounters& rays, std::uint64_t* bad) {
            const bool inside = x >= out.r.x0 && x < out.r.x1 && y >= out.r.y0 && y < out.r.y1;
            PixelSums margin;
            PixelSums* acc = inside ? &sums[out.index(x, y)] : &margin;
            sample_pixel(x, y, 0, pilot, acc, rays, bad, true);
            const double m = acc->y_sum / pilot;
            const std::size_t q = piloted.index(x, y);
            pilot_mean[q] = m;
            pilot_var[q] = pilot > 1 ? std::max(0.0, (acc->y_sum2 - pilot * m * m) / (pilot - 1.0)) : 0.0;
            return inside ? static_cast<std::uint64_t>(pilot) : std::uint64_t{0};
          },
          {});
      const double e2 = s.noise_threshold * s.noise_threshold;
      std::uint64_t below = 0, total = 0;
      for (int y = out.r.y0; y < out.r.y1; ++y)
        for (int x = out.r.x0; x < out.r.x1; ++x) {
          double m = 0.0, v = 0.0;
          int n = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int qx = x + dx, qy = y + dy;
              if ((dx == 0 && dy == 0) || qx < 0 || qy < 0 || qx >= s.width || qy >= s.height) continue;
              const std::size_t q = piloted.index(qx, qy);
              m += pilot_mean[q];
              v += pilot_var[q];
              ++n;
            }
          double target = s.spp;
          if (n > 0) {
            m /= n;
            v /= n;
            target = m > 0.0 ? std::ceil(v / (e2 * m * m)) : pilot;
          }
          const auto planned_n = static_cast<std::uint32_t>(std::clamp(target, static_cast<double>(pilot), static_cast<double>(s.spp)));
          planned[out.index(x, y)] = planned_n;
          below += planned_n < static_cast<std::uint32_t>(s.spp);
          total += planned_n;
        }
      converged = static_cast<double>(below) / static_cast<double>(pixels);
      if (progress.planned) progress.planned(total, converged);
      first_round = pilot;
    }
    std::atomic<bool> out_of_time{false};
    auto in_time = [&] {
      if (out_of_time.load()) return false;
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (s.time_limit > 0.0 && elapsed >= s.time_limit) out_of_time = true;
      return !out_of_time.load();
    };
    auto last_preview = std::chrono::steady_clock::now();
    for (int first = first_round; first < s.spp && !out_of_time.load(); first += kRoundSamples) {
      for_tiles(
          out,
          [&](int x, int y, RayCounters& rays, std::uint64_t* bad) {
            const std::size_t i = out.index(x, y);
            const int count = std::min(static_cast<int>(planned[i]) - first, kRoundSamples);
            if (count <= 0) return std::uint64_t{0};
            sample_pixel(x, y, first, count, &sums[i], rays, bad, false);
            return static_cast<std::uint64_t>(count);
          },
          first == 0 ? std::function<bool()>() : std::function<bool()>(in_time));  // round 0 always completes
      const auto now = std::chrono::steady_clock::now();
      if (progress.preview && s.preview_every > 0.0 && first + kRoundSamples < s.spp &&
          std::chrono::duration<double>(now - last_preview).count() >= s.preview_every) {
        Image so_far(image.width, image.height);
        std::uint64_t samples = 0;
        for (std::size_t i = 0; i < pixels; ++i) {
          resolve(i, sums[i], &so_far);
          samples += sums[i].count;
        }
        progress.preview(so_far, samples);
        last_preview = std::chrono::steady_clock::now();
      }
    }
    for (std::size_t i = 0; i < pixels; ++i) resolve(i, sums[i], &image);
    if (stats && (adaptive || s.time_limit > 0.0)) {
      stats->pixel_samples.resize(pixels);
      for (std::size_t i = 0; i < pixels; ++i) stats->pixel_samples[i] = sums[i].count;
      stats->pilot_samples = adaptive ? pixels * static_cast<std::uint64_t>(first_round) : 0;
      stats->time_limit_reached = out_of_time.load();
      stats->converged_fraction = converged;
    }
  }
  if (stats) {
    stats->clamped_samples = clamped_total;
    stats->rays.closest = counters.closest;
    stats->rays.camera = counters.camera;
    stats->rays.shadow = counters.shadow;
    stats->rays.scatter_events = counters.events;
    stats->invalid_samples = counters.invalid;
  }
  return image;
}

}  // namespace lamina
