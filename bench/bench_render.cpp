// Rays per second of the whole render loop (path tracing with NEE: camera, bounce and shadow
// rays, shading, sampling) next to Embree's own ceiling in the same run: a tight rtcIntersect1
// loop over the same BVH and the same camera rays (pre-generated, so the ceiling pays for
// nothing but traversal). Both on one thread.
//
// Camera rays are the cheapest rays there are (coherent; most miss a small object), so a
// second ceiling replays every ray the render loop traced (bounce rays with rtcIntersect1,
// shadow rays with rtcOccluded1) in a tight loop: the ratio to it is the share of the loop's
// time that Embree gets, i.e. what shading, sampling and bookkeeping cost.
//
//   bench_render [SCENE.glb ...]   (default: the Stanford bunny and the Lee Perry-Smith head)
//   env: LAMINA_BENCH_SIZE (default 256), LAMINA_BENCH_SPP (default 8)
#include <chrono>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

#include <embree3/rtcore.h>

#include "renderer/camera.h"
#include "renderer/integrator.h"
#include "renderer/lights.h"
#include "renderer/scene.h"
#include "renderer/scene_gltf.h"

using namespace lamina;

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : fallback;
}

void bench(const std::string& path, int size, int spp) {
  SceneDesc desc = load_gltf(path);
  const CameraDesc cam_desc = desc.cameras.empty() ? framing_camera(desc, 1.0) : desc.cameras.front();
  const Scene scene(std::move(desc));
  const EnvironmentMap env = EnvironmentMap::constant(Spectrum(1.0));
  const LightSet lights(scene, env);
  const Camera camera(cam_desc, size, size);

  // The render loop.
  RenderSettings s;
  s.width = s.height = size;
  s.spp = spp;
  s.threads = 1;
  s.max_depth = env_int("LAMINA_BENCH_DEPTH", 8);
  RenderStats stats;
  const double t0 = now();
  render_image(scene, lights, camera, s, &stats);
  const double render_seconds = now() - t0;
  const double rays = static_cast<double>(stats.rays.closest + stats.rays.shadow);

  if (std::getenv("LAMINA_BENCH_RENDER_ONLY")) {
    std::printf("%s: render loop %.3g Mrays/s\n", path.c_str(), rays / render_seconds / 1e6);
    return;
  }
  // The ceiling: the same camera rays (same Rng streams and filter samples) through rtcIntersect1.
  std::vector<RTCRayHit> camera_rays;
  camera_rays.reserve(static_cast<std::size_t>(size) * size * spp);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (int i = 0; i < spp; ++i) {
        Rng rng(s.seed, static_cast<std::uint64_t>(y) * size + x, static_cast<std::uint64_t>(i));
        const glm::dvec2 d = sample_tent_filter({rng.uniform(), rng.uniform()});
        const Ray r = camera.generate_ray({x + 0.5 + d.x, y + 0.5 + d.y});
        RTCRayHit rh{};
        rh.ray.org_x = static_cast<float>(r.origin.x);
        rh.ray.org_y = static_cast<float>(r.origin.y);
        rh.ray.org_z = static_cast<float>(r.origin.z);
        rh.ray.dir_x = static_cast<float>(r.direction.x);
        rh.ray.dir_y = static_cast<float>(r.direction.y);
        rh.ray.dir_z = static_cast<float>(r.direction.z);
        rh.ray.tfar = 3e38f;
        rh.ray.mask = 0xFFFFFFFFu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        camera_rays.push_back(rh);
      }
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  const auto rtc_scene = static_cast<RTCScene>(scene.embree_scene());
  const double t1 = now();
  std::size_t hits = 0;
  for (RTCRayHit& rh : camera_rays) {
    rtcIntersect1(rtc_scene, &context, &rh);
    hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  }
  const double ceiling_seconds = now() - t1;
  const double ceiling = camera_rays.size() / ceiling_seconds;
  const double loop = rays / render_seconds;
  std::printf("%s: %llu triangles, %dx%d, %d spp, 1 thread\n", path.c_str(),
              static_cast<unsigned long long>(scene.desc().triangles), size, size, spp);
  std::printf("  render loop: %.3g rays in %.2f s = %.3g Mrays/s (%.3g closest-hit, %.3g shadow)\n", rays, render_seconds,
              loop / 1e6, static_cast<double>(stats.rays.closest), static_cast<double>(stats.rays.shadow));
  std::printf("  embree ceiling (camera rays, rtcIntersect1): %zu rays (%zu hits) in %.2f s = %.3g Mrays/s\n",
              camera_rays.size(), hits, ceiling_seconds, ceiling / 1e6);
  std::printf("  ratio to the camera-ray ceiling: %.1f%%\n", 100.0 * loop / ceiling);

  // The replay ceiling: the render loop's own rays, recorded in a second (untimed) render.
  RayLog log;
  s.ray_log = &log;
  render_image(scene, lights, camera, s, nullptr);
  auto to_rtc = [](const Ray& r, float tfar, RTCRay* out) {
    *out = RTCRay{};
    out->org_x = static_cast<float>(r.origin.x);
    out->org_y = static_cast<float>(r.origin.y);
    out->org_z = static_cast<float>(r.origin.z);
    out->dir_x = static_cast<float>(r.direction.x);
    out->dir_y = static_cast<float>(r.direction.y);
    out->dir_z = static_cast<float>(r.direction.z);
    out->tfar = tfar;
    out->mask = 0xFFFFFFFFu;
  };
  std::vector<RTCRayHit> closest(log.closest.size());
  std::vector<RTCRay> shadow(log.shadow.size());
  for (std::size_t i = 0; i < closest.size(); ++i) {
    to_rtc(log.closest[i], 3e38f, &closest[i].ray);
    closest[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
  }
  for (std::size_t i = 0; i < shadow.size(); ++i)
    to_rtc(log.shadow[i].first, static_cast<float>(std::min(log.shadow[i].second, 3e38)), &shadow[i]);
  const double t2 = now();
  for (RTCRayHit& rh : closest) rtcIntersect1(rtc_scene, &context, &rh);
  for (RTCRay& r : shadow) rtcOccluded1(rtc_scene, &context, &r);
  const double replay_seconds = now() - t2;
  const double replay = (closest.size() + shadow.size()) / replay_seconds;
  std::printf("  embree replay of the loop's rays: %.3g rays in %.2f s = %.3g Mrays/s\n",
              static_cast<double>(closest.size() + shadow.size()), replay_seconds, replay / 1e6);
  std::printf("  ratio to the replay ceiling: %.1f%%\n", 100.0 * loop / replay);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes;
  for (int i = 1; i < argc; ++i) scenes.push_back(argv[i]);
  if (scenes.empty())
    scenes = {"/work/shared/assets/stanford_bunny/bunny.glb", LAMINA_SOURCE_DIR "/scenes/lee_perry_smith_head/head_lit.gltf"};
  const int size = env_int("LAMINA_BENCH_SIZE", 256), spp = env_int("LAMINA_BENCH_SPP", 8);
  try {
    for (const std::string& s : scenes) bench(s, size, spp);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_render: %s\n", e.what());
    return 1;
  }
  return 0;
}
