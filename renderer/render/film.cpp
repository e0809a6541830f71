#include "renderer/render/film.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "renderer/layered/shading.h"
#include "renderer/render/integrator.h"

namespace lamina {

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

int first_round_samples(const RenderSettings& s) {
  return s.noise_threshold > 0.0 ? std::clamp(s.pilot_spp, 1, s.spp) : std::min(kRoundSamples, s.spp);
}

namespace {

// Renders the samples of one render_image call into the image and its AOVs.
class Film {
 public:
  Film(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
       const RenderProgress& progress, RenderAovs* aovs);
  Image render(RenderStats* stats);

 private:
  // A tile's work per pixel: renders pixel (x, y) and returns how many samples (for the progress).
  using PixelWork = std::function<std::uint64_t(int, int, RayCounters&, std::uint64_t*)>;
  void sample_pixel(int x, int y, int first, int count, PixelSums* acc, RayCounters& rays, std::uint64_t* bad,
                    bool luminance) const;
  void resolve(std::size_t i, const PixelSums& acc, Image* target);
  void for_tiles(const Tiled& area, const PixelWork& work, const std::function<bool()>& keep_going);
  void render_one_pass();
  void render_in_rounds(RenderStats* stats);
  int plan_adaptive(std::vector<PixelSums>* sums, std::vector<std::uint32_t>* planned, double* converged);
  std::uint32_t planned_samples(int x, int y, const Tiled& piloted, const std::vector<double>& pilot_mean,
                                const std::vector<double>& pilot_var, int pilot) const;
  bool in_time();
  void preview(const std::vector<PixelSums>& sums);
  void write_stats(RenderStats* stats) const;

  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  const Camera& camera_;
  const RenderSettings& s_;
  const RenderProgress& progress_;
  const Shading shading_;
  const PathTracer tracer_;
  tbb::task_arena arena_;
  int workers_;
  const Tiled out_;
  const std::size_t pixels_;
  const AovSelection want_;
  const bool first_hits_;
  RenderAovs* aovs_;
  Image image_;
  TileCounters counters_;
  std::atomic<std::uint64_t> clamped_total_{0};
  std::atomic<bool> out_of_time_{false};
  std::chrono::steady_clock::time_point last_preview_;
};

int arena_threads(const RenderSettings& s) {
  return s.test_hooks.ray_log ? 1 : s.threads > 0 ? s.threads : tbb::task_arena::automatic;
}

int initialized_workers(tbb::task_arena& arena) {
  arena.initialize();
  return arena.max_concurrency();
}

Film::Film(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
           const RenderProgress& progress, RenderAovs* aovs)
    : camera_(camera),
      s_(s),
      progress_(progress),
      shading_(scene.desc(), s.layered, s.spectral),
      tracer_{scene, lights, shading_, s.max_depth},
      arena_(arena_threads(s)),
      workers_(initialized_workers(arena_)),
      out_(s.crop.empty() ? PixelRegion{0, 0, s.width, s.height} : s.crop, workers_),
      pixels_(out_.pixels()),
      want_(aovs ? s.aovs : AovSelection{}),
      first_hits_(want_.albedo || want_.normal || want_.depth),
      aovs_(aovs),
      image_(out_.width(), out_.r.y1 - out_.r.y0) {
  if (want_.albedo) aovs_->albedo = Image(image_.width, image_.height);
  if (want_.normal) aovs_->normal = Image(image_.width, image_.height);
  if (want_.variance) aovs_->variance = Image(image_.width, image_.height);
  if (want_.depth) aovs_->depth.assign(pixels_, 0.0f);
}

// Samples [first, first + count) of pixel (x, y) of the full image, added to *acc.
void Film::sample_pixel(int x, int y, int first, int count, PixelSums* acc, RayCounters& rays, std::uint64_t* bad,
                        bool luminance) const {
  const std::uint64_t pixel = static_cast<std::uint64_t>(y) * s_.width + x;
  for (int i = first; i < first + count; ++i) {
    if (progress_.cancel && progress_.cancel->load(std::memory_order_relaxed)) throw RenderCancelled();
    const std::uint64_t index = static_cast<std::uint64_t>(i);
    Rng rng(s_.seed, pixel, index);
    const glm::dvec2 d = sample_tent_filter({rng.uniform(), rng.uniform()});
    const Ray ray = camera_.generate_ray({x + 0.5 + d.x, y + 0.5 + d.y});
    ++rays.camera;
    PathShading path = shading_.start_path(s_.seed, pixel, index, &rays.scatter_events);
    FirstHit hit;
    Spectrum l = path_radiance(tracer_, ray, rng, path, &rays, first_hits_ ? &hit : nullptr);
    if (const SampledWavelengths* w = path.wavelengths()) {  // the spectral mode: to colour, through XYZ
      l = w->radiance_to_rgb(l);
      hit.albedo = w->reflectance_to_rgb(hit.albedo);
    }
    ++acc->count;
    if (!l.is_finite()) {
      ++*bad;
      continue;
    }
    if (s_.clamp > 0.0 && l.max() > s_.clamp) {
      l *= s_.clamp / l.max();
      ++acc->clamped;
    }
    acc->sum += l;
    if (want_.variance) acc->sum2 += l * l;
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
}

// The image's pixel i from its sums (and the AOVs', when the target is the image); a pixel with
// no samples is black.
void Film::resolve(std::size_t i, const PixelSums& acc, Image* target) {
  float* p = &target->rgb[i * 3];
  const double n = acc.count;
  for (int c = 0; c < 3; ++c) p[c] = acc.count > 0 ? static_cast<float>(acc.sum[c] / n) : 0.0f;
  if (target != &image_ || acc.count == 0) return;
  if (acc.clamped > 0) clamped_total_ += acc.clamped;
  for (int c = 0; c < 3; ++c) {
    if (want_.albedo) aovs_->albedo.rgb[i * 3 + c] = static_cast<float>(acc.albedo[c] / n);
    if (want_.normal) aovs_->normal.rgb[i * 3 + c] = static_cast<float>(acc.normal[c] / n);
    if (want_.variance)  // of the mean: the unbiased sample variance over n
      aovs_->variance.rgb[i * 3 + c] =
          acc.count > 1 ? static_cast<float>(std::max(0.0, acc.sum2[c] - acc.sum[c] * acc.sum[c] / n) / (n - 1.0) / n) : 0.0f;
  }
  if (want_.depth) aovs_->depth[i] = acc.hits > 0 ? static_cast<float>(acc.depth / acc.hits) : 0.0f;
}

// Runs work(x, y) for every pixel of every tile of `area`, in parallel; false from keep_going
// skips the tiles not yet started.
void Film::for_tiles(const Tiled& area, const PixelWork& work, const std::function<bool()>& keep_going) {
  arena_.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, area.tiles, 1), [&](const tbb::blocked_range<int>& range) {
      for (int tile = range.begin(); tile != range.end(); ++tile) {
        if (keep_going && !keep_going()) continue;
        const int x0 = area.r.x0 + (tile % area.tiles_x) * area.side, y0 = area.r.y0 + (tile / area.tiles_x) * area.side;
        const int x1 = std::min(x0 + area.side, area.r.x1), y1 = std::min(y0 + area.side, area.r.y1);
        RayCounters rays;
        rays.log = s_.test_hooks.ray_log;
        std::uint64_t bad = 0, done = 0;
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) done += work(x, y, rays, &bad);
        counters_.add(rays, bad);
        if (progress_.advance) progress_.advance(done);
      }
    });
  });
}

// Every pixel its spp samples in one pass.
void Film::render_one_pass() {
  for_tiles(
      out_,
      [&](int x, int y, RayCounters& rays, std::uint64_t* bad) {
        PixelSums acc;
        sample_pixel(x, y, 0, s_.spp, &acc, rays, bad, false);
        resolve(out_.index(x, y), acc, &image_);
        return static_cast<std::uint64_t>(s_.spp);
      },
      {});
}

// Pixel (x, y)'s planned samples from the pilot pass of its neighbours (the scheme above).
std::uint32_t Film::planned_samples(int x, int y, const Tiled& piloted, const std::vector<double>& pilot_mean,
                                    const std::vector<double>& pilot_var, int pilot) const {
  const double e2 = s_.noise_threshold * s_.noise_threshold;
  double m = 0.0, v = 0.0;
  int n = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if ((dx == 0 && dy == 0) || qx < 0 || qy < 0 || qx >= s_.width || qy >= s_.height) continue;
      const std::size_t q = piloted.index(qx, qy);
      m += pilot_mean[q];
      v += pilot_var[q];
      ++n;
    }
  double target = s_.spp;
  if (n > 0) {
    m /= n;
    v /= n;
    target = m > 0.0 ? std::ceil(v / (e2 * m * m)) : pilot;
  }
  return static_cast<std::uint32_t>(std::clamp(target, static_cast<double>(pilot), static_cast<double>(s_.spp)));
}

// The adaptive pilot pass (its samples stay in *sums) and each pixel's plan; returns the
// samples per pixel the pilot rendered.
int Film::plan_adaptive(std::vector<PixelSums>* sums, std::vector<std::uint32_t>* planned, double* converged) {
  const int pilot = first_round_samples(s_);
  // The region and a one-pixel margin (the neighbours of its edge pixels).
  const Tiled piloted(PixelRegion{std::max(out_.r.x0 - 1, 0), std::max(out_.r.y0 - 1, 0), std::min(out_.r.x1 + 1, s_.width),
                                  std::min(out_.r.y1 + 1, s_.height)}, workers_);
  std::vector<double> pilot_mean(piloted.pixels()), pilot_var(piloted.pixels());
  for_tiles(
      piloted,
      [&](int x, int y, RayCounters& rays, std::uint64_t* bad) {
        const bool inside = x >= out_.r.x0 && x < out_.r.x1 && y >= out_.r.y0 && y < out_.r.y1;
        PixelSums margin;
        PixelSums* acc = inside ? &(*sums)[out_.index(x, y)] : &margin;
        sample_pixel(x, y, 0, pilot, acc, rays, bad, true);
        const double m = acc->y_sum / pilot;
        const std::size_t q = piloted.index(x, y);
        pilot_mean[q] = m;
        pilot_var[q] = pilot > 1 ? std::max(0.0, (acc->y_sum2 - pilot * m * m) / (pilot - 1.0)) : 0.0;
        return inside ? static_cast<std::uint64_t>(pilot) : std::uint64_t{0};
      },
      {});
  std::uint64_t below = 0, total = 0;
  for (int y = out_.r.y0; y < out_.r.y1; ++y)
    for (int x = out_.r.x0; x < out_.r.x1; ++x) {
      const std::uint32_t planned_n = planned_samples(x, y, piloted, pilot_mean, pilot_var, pilot);
      (*planned)[out_.index(x, y)] = planned_n;
      below += planned_n < static_cast<std::uint32_t>(s_.spp);
      total += planned_n;
    }
  *converged = static_cast<double>(below) / static_cast<double>(pixels_);
  if (progress_.planned) progress_.planned(total, *converged);
  return pilot;
}

// False once the time limit is spent (and from then on).
bool Film::in_time() {
  if (out_of_time_.load()) return false;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (s_.time_limit > 0.0 && elapsed >= s_.time_limit) out_of_time_ = true;
  return !out_of_time_.load();
}

// The image so far (each pixel the mean of its samples so far), to progress_.preview.
void Film::preview(const std::vector<PixelSums>& sums) {
  Image so_far(image_.width, image_.height);
  std::uint64_t samples = 0;
  for (std::size_t i = 0; i < pixels_; ++i) {
    resolve(i, sums[i], &so_far);
    samples += sums[i].count;
  }
  progress_.preview(so_far, samples);
  last_preview_ = std::chrono::steady_clock::now();
}

// The planned samples in rounds of kRoundSamples over the whole image (after the adaptive
// pilot), with the time limit and the previews between rounds.
void Film::render_in_rounds(RenderStats* stats) {
  const bool adaptive = s_.noise_threshold > 0.0;
  std::vector<std::uint32_t> planned(pixels_, static_cast<std::uint32_t>(s_.spp));
  double converged = 0.0;
  std::vector<PixelSums> sums(pixels_);
  const int first_round = adaptive ? plan_adaptive(&sums, &planned, &converged) : 0;
  last_preview_ = std::chrono::steady_clock::now();
  for (int first = first_round; first < s_.spp && !out_of_time_.load(); first += kRoundSamples) {
    for_tiles(
        out_,
        [&](int x, int y, RayCounters& rays, std::uint64_t* bad) {
          const std::size_t i = out_.index(x, y);
          const int count = std::min(static_cast<int>(planned[i]) - first, kRoundSamples);
          if (count <= 0) return std::uint64_t{0};
          sample_pixel(x, y, first, count, &sums[i], rays, bad, false);
          return static_cast<std::uint64_t>(count);
        },
        first == 0 ? std::function<bool()>() : std::function<bool()>([this] { return in_time(); }));  // round 0 always completes
    const auto now = std::chrono::steady_clock::now();
    if (progress_.preview && s_.preview_every > 0.0 && first + kRoundSamples < s_.spp &&
        std::chrono::duration<double>(now - last_preview_).count() >= s_.preview_every)
      preview(sums);
  }
  for (std::size_t i = 0; i < pixels_; ++i) resolve(i, sums[i], &image_);
  if (stats && (adaptive || s_.time_limit > 0.0)) {
    stats->pixel_samples.resize(pixels_);
    for (std::size_t i = 0; i < pixels_; ++i) stats->pixel_samples[i] = sums[i].count;
    stats->pilot_samples = adaptive ? pixels_ * static_cast<std::uint64_t>(first_round) : 0;
    stats->time_limit_reached = out_of_time_.load();
    stats->converged_fraction = converged;
  }
}

void Film::write_stats(RenderStats* stats) const {
  stats->clamped_samples = clamped_total_;
  stats->rays.closest = counters_.closest;
  stats->rays.camera = counters_.camera;
  stats->rays.shadow = counters_.shadow;
  stats->rays.scatter_events = counters_.events;
  stats->invalid_samples = counters_.invalid;
}

Image Film::render(RenderStats* stats) {
  const bool rounds =
      s_.noise_threshold > 0.0 || s_.time_limit > 0.0 || (s_.preview_every > 0.0 && progress_.preview);
  if (rounds)
    render_in_rounds(stats);
  else
    render_one_pass();
  if (stats) write_stats(stats);
  return std::move(image_);
}

}  // namespace

Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
                   RenderStats* stats, const std::function<void(std::uint64_t)>& on_progress) {
  RenderProgress progress;
  progress.advance = on_progress;
  return render_image(scene, lights, camera, s, stats, progress);
}

Image render_image(const Scene& scene, const LightSet& lights, const Camera& camera, const RenderSettings& s,
                   RenderStats* stats, const RenderProgress& progress, RenderAovs* aovs) {
  Film film(scene, lights, camera, s, progress, aovs);
  return film.render(stats);
}

}  // namespace lamina
