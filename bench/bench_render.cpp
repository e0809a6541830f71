// Rays per second of the whole render loop next to Embree's own ceiling in the same run.
//
// The render loop: render_image() on one thread (path tracing with next-event estimation:
// camera, bounce and shadow rays, shading, sampling, light choice, filter, film). Its rate is
// every ray it traced (closest-hit camera and bounce rays plus shadow rays) divided by the time
// of the whole render.
//
// The ceiling: a tight rtcIntersect1 loop over the same BVH and the same camera rays (the
// render's own Rng streams and filter samples, generated beforehand so the loop pays for
// traversal only). Goal: render loop >= 70 % of the ceiling's rays per second.
//
// A second, stricter ceiling replays every ray the render loop traced (bounce rays with
// rtcIntersect1, shadow rays with rtcOccluded1) in a tight loop: the ratio to it is the share
// of the loop's time that Embree gets, i.e. what shading, sampling and bookkeeping cost.
//
// Times are process CPU time, best of LAMINA_BENCH_REPEAT runs (the machine is shared: wall
// clock is printed too but swings with other jobs' load).
//
// Two cameras per scene:
//   scene  : the file's first camera, or framing_camera() (what `lamina render` uses)
//   framed : the scene camera's direction, re-aimed and zoomed so that the object's projected
//            vertices just fill the image; most camera rays hit, as in real close-up use.
//
//   bench_render [SCENE.glb ...]   (default: the Stanford bunny and the Lee Perry-Smith head)
//   env: LAMINA_BENCH_SIZE (256), LAMINA_BENCH_SPP (8), LAMINA_BENCH_DEPTH (8),
//        LAMINA_BENCH_REPEAT (3), LAMINA_BENCH_CAMERA (both | scene | framed),
//        LAMINA_BENCH_RENDER_ONLY (set: no ceilings, one render; for profilers),
//        LAMINA_BENCH_NO_REPLAY (set: skip the replay ceiling).
// Instruction counts of the loop and the ceiling: bench/callgrind_render.sh (callgrind with
// --toggle-collect on timed_render and ceiling_loop).
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <stdexcept>
#include <vector>

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>

#include "renderer/scene/camera.h"
#include "renderer/image/image.h"
#include "materials/base/sampling.h"
#include "renderer/render/film.h"
#include "renderer/render/lights.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"

using namespace lamina;

namespace {

struct Clock {
  double wall, cpu;
};

Clock now() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return {std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(),
          static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec)};
}

struct Timing {
  double wall = 1e300, cpu = 1e300;  // best of the repeats
  void add(const Clock& a, const Clock& b) {
    wall = std::min(wall, b.wall - a.wall);
    cpu = std::min(cpu, b.cpu - a.cpu);
  }
};

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : fallback;
}

// The scene camera's view direction, re-aimed at the centre of the object's projected
// vertices and given the vertical field of view at which they just fill the image (square
// pixels, `aspect` = width / height). Two passes: re-aiming changes the projection a little.
CameraDesc framed_camera(const SceneDesc& desc, CameraDesc cam, double aspect) {
  for (int pass = 0; pass < 2; ++pass) {
    const glm::dvec3 f = glm::normalize(cam.forward);
    glm::dvec3 r = glm::cross(f, cam.up);
    if (glm::length(r) < 1e-9) r = glm::cross(f, glm::dvec3(1.0, 0.0, 0.0));
    r = glm::normalize(r);
    const glm::dvec3 u = glm::cross(r, f);
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (const Mesh& m : desc.meshes)
      for (const glm::vec3& p : m.positions) {
        const glm::dvec3 v = glm::dvec3(p) - cam.position;
        const double z = glm::dot(v, f);
        if (!(z > 1e-9)) continue;  // behind the camera: cannot be framed by turning alone
        x0 = std::min(x0, glm::dot(v, r) / z), x1 = std::max(x1, glm::dot(v, r) / z);
        y0 = std::min(y0, glm::dot(v, u) / z), y1 = std::max(y1, glm::dot(v, u) / z);
      }
    if (!(x1 > x0 && y1 > y0)) return cam;
    // Aim through the centre of the projected rectangle (at unit distance); the half extents
    // are then measured about it in the next pass, so the second pass's fov is the one kept.
    cam.forward = glm::normalize(f + 0.5 * (x0 + x1) * r + 0.5 * (y0 + y1) * u);
    cam.up = u;
    cam.yfov = 2.0 * std::atan(std::max(0.5 * (y1 - y0), 0.5 * (x1 - x0) / aspect));
  }
  cam.name = "(framed)";
  return cam;
}

// The ceiling: nothing but traversal. Not inlined, so callgrind can count it alone.
__attribute__((noinline)) std::size_t ceiling_loop(RTCScene scene, std::vector<RTCRayHit>* rays) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  std::size_t hits = 0;
  for (RTCRayHit& rh : *rays) {
    rtcIntersect1(scene, &context, &rh);
    hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  }
  return hits;
}

__attribute__((noinline)) void replay_loop(RTCScene scene, std::vector<RTCRayHit>* closest,
                                           std::vector<RTCRay>* shadow) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  for (RTCRayHit& rh : *closest) rtcIntersect1(scene, &context, &rh);
  for (RTCRay& r : *shadow) rtcOccluded1(scene, &context, &r);
}

// The timed render (a named function, so callgrind can count it alone).
__attribute__((noinline)) Image timed_render(const Scene& scene, const LightSet& lights, const Camera& camera,
                                             const RenderSettings& s, RenderStats* stats) {
  return render_image(scene, lights, camera, s, stats);
}

// Optimisations must not change the image beyond floating-point noise: with
// LAMINA_BENCH_SAVE=DIR the rendered images are written there (raw floats), with
// LAMINA_BENCH_COMPARE=DIR compared with those (bit-identical, or the largest difference).
void save_or_compare(const Image& image, const std::string& key) {
  std::string name = key;
  for (char& c : name)
    if (c == '/' || c == '.' || c == ' ') c = '_';
  if (const char* dir = std::getenv("LAMINA_BENCH_SAVE")) {
    FILE* f = std::fopen((std::string(dir) + "/" + name + ".raw").c_str(), "wb");
    if (!f) throw std::runtime_error(std::string(dir) + ": cannot write " + name + ".raw");
    std::fwrite(image.rgb.data(), sizeof(float), image.rgb.size(), f);
    std::fclose(f);
  }
  if (const char* dir = std::getenv("LAMINA_BENCH_COMPARE")) {
    std::vector<float> ref(image.rgb.size());
    FILE* f = std::fopen((std::string(dir) + "/" + name + ".raw").c_str(), "rb");
    if (!f || std::fread(ref.data(), sizeof(float), ref.size(), f) != ref.size())
      throw std::runtime_error(std::string(dir) + "/" + name + ".raw: missing or wrong size");
    std::fclose(f);
    double max_abs = 0.0, sum = 0.0, sum_ref = 0.0;
    std::size_t differ = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      const double d = std::fabs(static_cast<double>(image.rgb[i]) - ref[i]);
      max_abs = std::max(max_abs, d);
      differ += image.rgb[i] != ref[i];
      sum += image.rgb[i];
      sum_ref += ref[i];
    }
    std::printf("    vs reference: %zu of %zu values differ, largest difference %.3g, mean %.9g vs %.9g\n", differ,
                ref.size(), max_abs, sum / ref.size(), sum_ref / ref.size());
  }
}

void to_rtc(const Ray& r, float tfar, RTCRay* out) {
  *out = RTCRay{};
  out->org_x = static_cast<float>(r.origin.x);
  out->org_y = static_cast<float>(r.origin.y);
  out->org_z = static_cast<float>(r.origin.z);
  out->dir_x = static_cast<float>(r.direction.x);
  out->dir_y = static_cast<float>(r.direction.y);
  out->dir_z = static_cast<float>(r.direction.z);
  out->tfar = tfar;
  out->mask = 0xFFFFFFFFu;
}

void bench_camera(const Scene& scene, const LightSet& lights, const CameraDesc& cam_desc, const char* label,
                  int size, int spp, int repeat) {
  const Camera camera(cam_desc, size, size);
  RenderSettings s;
  s.width = s.height = size;
  s.spp = spp;
  s.threads = 1;
  s.max_depth = env_int("LAMINA_BENCH_DEPTH", 8);
  const auto rtc_scene = static_cast<RTCScene>(scene.embree_scene());

  if (std::getenv("LAMINA_BENCH_RENDER_ONLY")) {
    RenderStats stats;
    Timing t;
    for (int k = 0; k < repeat; ++k) {
      const Clock a = now();
      timed_render(scene, lights, camera, s, &stats);
      t.add(a, now());
    }
    const double rays = static_cast<double>(stats.rays.closest + stats.rays.shadow);
    std::printf("  %s camera: render loop %.3g Mrays/s (cpu)\n", label, rays / t.cpu / 1e6);
    return;
  }

  // The camera rays, exactly as render_image() makes them (same Rng streams and filter).
  std::vector<RTCRayHit> camera_rays(static_cast<std::size_t>(size) * size * spp);
  for (int y = 0, k = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (int i = 0; i < spp; ++i, ++k) {
        Rng rng(s.seed, static_cast<std::uint64_t>(y) * size + x, static_cast<std::uint64_t>(i));
        const glm::dvec2 d = sample_tent_filter({rng.uniform(), rng.uniform()});
        to_rtc(camera.generate_ray({x + 0.5 + d.x, y + 0.5 + d.y}), 3e38f, &camera_rays[k].ray);
        camera_rays[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
      }

  // Render and ceiling alternate, so a burst of load from other jobs hits both alike.
  Timing render_t, ceiling_t;
  RenderStats stats;
  Image image;
  std::size_t hits = 0;
  for (int k = 0; k < repeat; ++k) {
    std::vector<RTCRayHit> fresh = camera_rays;
    const Clock a = now();
    hits = ceiling_loop(rtc_scene, &fresh);
    const Clock b = now();
    ceiling_t.add(a, b);
    const Clock c = now();
    image = timed_render(scene, lights, camera, s, &stats);
    const Clock d = now();
    render_t.add(c, d);
  }
  save_or_compare(image, std::string(label) + "_" + scene.desc().path.substr(scene.desc().path.rfind('/') + 1));
  const double rays = static_cast<double>(stats.rays.closest + stats.rays.shadow);
  const double loop = rays / render_t.cpu, ceiling = camera_rays.size() / ceiling_t.cpu;
  std::printf("  %s camera (%s): %.0f%% of camera rays hit\n", label, cam_desc.name.c_str(),
              100.0 * hits / camera_rays.size());
  std::printf("    render loop: %.0f rays (%.0f closest-hit, %.0f shadow) in %.3f s cpu (%.3f wall) = %.3g Mrays/s\n",
              rays, static_cast<double>(stats.rays.closest), static_cast<double>(stats.rays.shadow), render_t.cpu,
              render_t.wall, loop / 1e6);
  std::printf("    embree ceiling (camera rays, rtcIntersect1): %zu rays in %.3f s cpu (%.3f wall) = %.3g Mrays/s\n",
              camera_rays.size(), ceiling_t.cpu, ceiling_t.wall, ceiling / 1e6);
  std::printf("    ratio to the camera-ray ceiling: %.1f%% (cpu), %.1f%% (wall)\n", 100.0 * loop / ceiling,
              100.0 * (rays / render_t.wall) / (camera_rays.size() / ceiling_t.wall));

  if (std::getenv("LAMINA_BENCH_NO_REPLAY")) return;
  // The replay ceiling: the render loop's own rays, recorded in one more (untimed) render.
  RayLog log;
  s.test_hooks.ray_log = &log;
  render_image(scene, lights, camera, s, nullptr);
  std::vector<RTCRayHit> closest(log.closest.size());
  std::vector<RTCRay> shadow(log.shadow.size());
  for (std::size_t i = 0; i < closest.size(); ++i) {
    to_rtc(log.closest[i], 3e38f, &closest[i].ray);
    closest[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
  }
  for (std::size_t i = 0; i < shadow.size(); ++i)
    to_rtc(log.shadow[i].first, static_cast<float>(std::min(log.shadow[i].second, 3e38)), &shadow[i]);
  Timing replay_t;
  for (int k = 0; k < repeat; ++k) {
    std::vector<RTCRayHit> c = closest;
    std::vector<RTCRay> sh = shadow;
    const Clock a = now();
    replay_loop(rtc_scene, &c, &sh);
    const Clock b = now();
    replay_t.add(a, b);
  }
  const double replay = (closest.size() + shadow.size()) / replay_t.cpu;
  std::printf("    embree replay of the loop's rays: %.3g rays in %.3f s cpu = %.3g Mrays/s\n",
              static_cast<double>(closest.size() + shadow.size()), replay_t.cpu, replay / 1e6);
  std::printf("    ratio to the replay ceiling: %.1f%% (Embree's share of the render loop's time)\n",
              100.0 * loop / replay);
}

void bench(const std::string& path, int size, int spp, int repeat) {
  SceneDesc desc = load_gltf(path);
  const CameraDesc scene_cam = desc.cameras.empty() ? framing_camera(desc, 1.0) : desc.cameras.front();
  const CameraDesc framed = framed_camera(desc, scene_cam, 1.0);
  const Scene scene(std::move(desc));
  const EnvironmentMap env = EnvironmentMap::constant(Spectrum(1.0));
  const LightSet lights(scene, env);
  std::printf("%s: %llu triangles, %dx%d, %d spp, 1 thread, best of %d\n", path.c_str(),
              static_cast<unsigned long long>(scene.desc().triangles), size, size, spp, repeat);
  const char* which = std::getenv("LAMINA_BENCH_CAMERA");
  const std::string w = which ? which : "both";
  if (w == "both" || w == "scene") bench_camera(scene, lights, scene_cam, "scene", size, spp, repeat);
  if (w == "both" || w == "framed") bench_camera(scene, lights, framed, "framed", size, spp, repeat);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes;
  for (int i = 1; i < argc; ++i) scenes.push_back(argv[i]);
  if (scenes.empty())
    scenes = {"/work/shared/assets/stanford_bunny/bunny.glb", LAMINA_SOURCE_DIR "/scenes/lee_perry_smith_head/head_lit.gltf"};
  const int size = env_int("LAMINA_BENCH_SIZE", 256), spp = env_int("LAMINA_BENCH_SPP", 8);
  const int repeat = std::max(1, env_int("LAMINA_BENCH_REPEAT", 3));
  try {
    for (const std::string& s : scenes) bench(s, size, spp, repeat);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_render: %s\n", e.what());
    return 1;
  }
  return 0;
}
