// The path tracer against answers known in closed form. Scenes are built in code (the glTF
// loader has its own tests). Tolerances: the image mean of N pixels, each an independent
// estimate of the same expected radiance, has standard error s/sqrt(N) with s the sample
// standard deviation of the pixels; we allow 4 standard errors (two-sided false alarm 6e-5).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/base/sampling.h"
#include "renderer/render/film.h"
#include "tests/renderer/render_fixtures.h"

namespace lamina {
namespace {

using test::add_quad;
using test::camera_at;
using test::cube;
using test::lambert_plane;
using test::ImageStats;
using test::make_scene;
using test::sphere;
using test::stats_of;

Image render(const SceneDesc& desc, const EnvironmentMap& env, const CameraDesc& cam, int w, int h, int spp,
             int max_depth = 1000, int threads = 0, RenderStats* stats_out = nullptr,
             const RenderSettings& base = RenderSettings{}) {
  RenderSettings s = base;
  s.width = w;
  s.height = h;
  s.spp = spp;
  s.seed = 7;
  s.max_depth = max_depth;
  s.threads = threads;
  return test::render_valid(Scene{SceneDesc(desc)}, env, cam, s, stats_out);
}

// A closed box of coloured Lambert walls lit by a small emissive quad under its ceiling, seen from
// inside: area-light sampling, MIS and several bounces, with pixels of very different noise.
SceneDesc lit_box() {
  Material wall;
  wall.base_color = Spectrum(0.7, 0.5, 0.3);
  Material lamp;
  lamp.emission = Spectrum(5.0);
  lamp.double_sided = true;
  Mesh light;
  add_quad(&light, {-0.3f, 0.99f, -0.3f}, {0.3f, 0.99f, -0.3f}, {0.3f, 0.99f, 0.3f}, {-0.3f, 0.99f, 0.3f});
  light.material = 1;
  return make_scene({cube(0), light}, {wall, lamp});
}

// Closed Lambert enclosure of albedo a whose walls all emit Le: L = Le + a L everywhere (the
// irradiance inside a closed uniform-radiance enclosure is pi L, for any shape), so
// L = Le / (1 - a). Exercises triangle lights, MIS at every bounce and Russian roulette.
TEST(Integrator, EmissiveFurnaceEnclosure) {
  for (double a : {0.0, 0.5, 0.8}) {
    Material mat;
    mat.base_color = Spectrum(a);
    mat.emission = Spectrum(1.0, 0.5, 2.0);
    mat.double_sided = true;
    const SceneDesc d = make_scene({cube(0)}, {mat});
    const Image im = render(d, EnvironmentMap(), camera_at({0.1, 0.2, 0.3}, {0.3, -0.2, -1.0}, 70.0), 24, 16, 16);
    const ImageStats s = stats_of(im);
    for (int c = 0; c < 3; ++c) {
      const double expected = mat.emission[c] / (1.0 - a);
      EXPECT_NEAR(s.mean[c], expected, 4.0 * s.stderr_[c] + 1e-6 * expected) << "a=" << a << " channel " << c;
    }
  }
}

// A convex Lambert object of albedo a under a uniform environment Le: every bounce escapes,
// so L = a Le (a = 1: the white furnace, L = Le). Exercises environment light sampling + MIS.
TEST(Integrator, EnvironmentFurnaceConvexObject) {
  for (double a : {0.3, 1.0}) {
    Material mat;
    mat.base_color = Spectrum(a);
    const SceneDesc d = make_scene({cube(0)}, {mat});
    const EnvironmentMap env = EnvironmentMap::constant(Spectrum(0.5, 1.0, 2.0));
    // From z = 3, a 10 degree field of view sees only the front face (half-height 0.17 < 1).
    const Image im = render(d, env, camera_at({0.0, 0.0, 3.0}, {0.0, 0.0, -1.0}, 10.0), 16, 16, 64);
    const ImageStats s = stats_of(im);
    for (int c = 0; c < 3; ++c) {
      const double expected = a * env.eval({0.0, 1.0, 0.0})[c];
      EXPECT_NEAR(s.mean[c], expected, 4.0 * s.stderr_[c] + 1e-6) << "a=" << a << " channel " << c;
    }
  }
}

// A point light of intensity pi at the centre of a unit sphere of albedo 1/2: direct
// irradiance pi, so L = (a/pi)(pi + pi L) gives L = 1 on an exact sphere (all bounces). The
// tessellated sphere's facets lie at distances h_f in [h, 1] from the centre, so direct
// irradiance I h_f / d^3 lies in [I h, I / h^2] and, by the same balance, L in [h, 1/h^2].
TEST(Integrator, PointLightInsideSphere) {
  Material mat;
  mat.base_color = Spectrum(0.5);
  SceneDesc d = make_scene({sphere(0, 48, 96)}, {mat});
  LightDesc light;
  light.type = LightType::kPoint;
  light.intensity = Spectrum(kPi);
  d.lights.push_back(light);
  double h = 1.0;
  const Mesh& m = d.meshes[0];
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const glm::dvec3 p0(m.positions[m.indices[t]]), p1(m.positions[m.indices[t + 1]]), p2(m.positions[m.indices[t + 2]]);
    h = std::min(h, std::abs(glm::dot(glm::normalize(glm::cross(p1 - p0, p2 - p0)), p0)));
  }
  ASSERT_GT(h, 0.99);
  const Image im = render(d, EnvironmentMap(), camera_at({0.0, 0.0, 0.0}, {0.2, 0.1, -1.0}, 80.0), 24, 16, 16);
  const ImageStats s = stats_of(im);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GE(s.mean[c], h - 4.0 * s.stderr_[c]);
    EXPECT_LE(s.mean[c], 1.0 / (h * h) + 4.0 * s.stderr_[c]);
  }
}

// A Lambert plane of albedo a under a directional light of irradiance E at 60 degrees from the
// normal: L = a E cos(theta) / pi, with zero variance (one delta light, the bounce escapes).
TEST(Integrator, LambertPlaneUnderDirectionalLight) {
  const Spectrum albedo(0.6, 0.3, 0.9);
  SceneDesc d = lambert_plane(albedo);
  LightDesc sun;
  sun.type = LightType::kDirectional;
  sun.intensity = Spectrum(2.0);
  const double theta = kPi / 3.0;
  sun.direction = glm::normalize(glm::dvec3(std::sin(theta), -std::cos(theta), 0.0));
  d.lights.push_back(sun);
  const Image im = render(d, EnvironmentMap(), camera_at({0.0, 5.0, 0.0}, {0.0, -1.0, 0.0}, 40.0), 8, 8, 4);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) {
        const double expected = albedo[c] * 2.0 * std::cos(theta) / kPi;
        EXPECT_NEAR(im.pixel(x, y)[c], expected, 1e-6 * expected);
      }
}

// Point and spot lights of intensity I straight above a Lambert plane at height h: L = a I/(pi h^2)
// at the foot of the light (one pixel of a 0.001 degree field of view, symmetric about the foot: cos and 1/d^2 vary
// by < 1e-8 over it); a spot aimed away from the plane gives 0; halfway through the falloff
// ramp, t = 1/2 gives attenuation 1/4.
TEST(Integrator, PointAndSpotLightsAbovePlane) {
  Material mat;
  mat.base_color = Spectrum(0.5);
  Mesh plane;
  add_quad(&plane, {-100, 0, 100}, {100, 0, 100}, {100, 0, -100}, {-100, 0, -100});
  plane.material = 0;
  const double h = 5.0, intensity = 7.0;
  auto radiance_below = [&](LightType type, glm::dvec3 direction, double cos_inner, double cos_outer) {
    SceneDesc d = make_scene({plane}, {mat});
    LightDesc l;
    l.type = type;
    l.intensity = Spectrum(intensity);
    l.position = {0.0, h, 0.0};
    l.direction = direction;
    l.cos_inner = cos_inner;
    l.cos_outer = cos_outer;
    d.lights.push_back(l);
    const Image im = render(d, EnvironmentMap(), camera_at({0.0, 2.0 * h, 0.0}, {0.0, -1.0, 0.0}, 0.001), 1, 1, 4);
    return static_cast<double>(im.pixel(0, 0)[0]);
  };
  const double expected = 0.5 * intensity / (kPi * h * h);
  EXPECT_NEAR(radiance_below(LightType::kPoint, {0, -1, 0}, 1, 0), expected, 1e-6 * expected);
  EXPECT_NEAR(radiance_below(LightType::kSpot, {0, -1, 0}, std::cos(0.3), std::cos(0.5)), expected, 1e-6 * expected);
  EXPECT_EQ(radiance_below(LightType::kSpot, {0, 1, 0}, std::cos(0.3), std::cos(0.5)), 0.0);
  // Aim the spot so the plane's foot point sits at cos = (cos_inner + cos_outer)/2.
  const double ci = std::cos(0.3), co = std::cos(0.5), c = 0.5 * (ci + co);
  const glm::dvec3 tilted(std::sqrt(1.0 - c * c), -c, 0.0);
  // On the ramp, attenuation t^2 changes by 2 dt/t = 2 sin(theta) d(theta) / (t (ci - co)); the
  // pixel's samples reach at most 1.5 pixel widths (2h tan(fov/2) each, seen from distance 2h)
  // from the foot, i.e. d(theta) <= 3 h tan(fov/2) / h, seen from the light at distance h.
  const double dtheta = 3.0 * std::tan(0.5 * 0.001 * kPi / 180.0) * 2.0 * h / h;
  const double rel = 2.0 * std::sqrt(1.0 - c * c) * dtheta / (0.5 * (ci - co));
  EXPECT_NEAR(radiance_below(LightType::kSpot, tilted, ci, co), 0.25 * expected, rel * 0.25 * expected);
}

// An emissive quad seen directly shows its radiance exactly, from the front only.
TEST(Integrator, EmissiveQuadSeenDirectly) {
  Material mat;
  mat.base_color = Spectrum(0.0);
  mat.emission = Spectrum(1.0, 2.0, 3.0);
  Mesh quad;
  add_quad(&quad, {-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0});  // normal +z
  quad.material = 0;
  const SceneDesc d = make_scene({quad}, {mat});
  const Image front = render(d, EnvironmentMap(), camera_at({0, 0, 5}, {0, 0, -1}, 30.0), 8, 8, 2);
  const Image back = render(d, EnvironmentMap(), camera_at({0, 0, -5}, {0, 0, 1}, 30.0), 8, 8, 2);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(front.pixel(x, y)[c], static_cast<float>(mat.emission[c]));
        EXPECT_EQ(back.pixel(x, y)[c], 0.0f);
      }
}

// Bit-identical images for 1 and 2 threads (and the same ray counts).
TEST(Integrator, DeterministicAcrossThreadCounts) {
  Material wall;
  wall.base_color = Spectrum(0.7, 0.5, 0.3);
  Material lamp;
  lamp.emission = Spectrum(5.0);
  Mesh box = cube(0);
  Mesh light;
  add_quad(&light, {-0.3f, 0.99f, -0.3f}, {0.3f, 0.99f, -0.3f}, {0.3f, 0.99f, 0.3f}, {-0.3f, 0.99f, 0.3f});
  light.material = 1;
  lamp.double_sided = true;
  const SceneDesc d = make_scene({box, light}, {wall, lamp});
  const CameraDesc cam = camera_at({0.0, 0.0, 0.9}, {0.0, 0.0, -1.0}, 60.0);
  RenderStats s1, s2;
  const Image a = render(d, EnvironmentMap(), cam, 40, 36, 4, 64, 1, &s1);
  const Image b = render(d, EnvironmentMap(), cam, 40, 36, 4, 64, 2, &s2);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
  EXPECT_EQ(s1.rays.closest, s2.rays.closest);
  EXPECT_EQ(s1.rays.shadow, s2.rays.shadow);
  EXPECT_EQ(s1.rays.camera, 40u * 36u * 4u);
  // An image that 1 worker renders in 16x16 tiles and 3 workers in 8x8 ones (the tile side
  // depends on the workers, integrator.cpp), neither dividing its size: the same image, and every
  // pixel rendered exactly once.
  RenderStats s3, s4;
  const Image c = render(d, EnvironmentMap(), cam, 203, 151, 1, 64, 1, &s3);
  const Image e = render(d, EnvironmentMap(), cam, 203, 151, 1, 64, 3, &s4);
  ASSERT_EQ(c.rgb.size(), e.rgb.size());
  EXPECT_EQ(0, std::memcmp(c.rgb.data(), e.rgb.data(), c.rgb.size() * sizeof(float)));
  EXPECT_EQ(s3.rays.camera, 203u * 151u);
  EXPECT_EQ(s4.rays.camera, 203u * 151u);
}

// ---- adaptive sampling and the time limit (render_image) ----

// The emissive Lambert enclosure (L = Le / (1 - a), a = 0.8: long paths, noisy pixels) with
// adaptive sampling: each pixel's count is planned from its neighbours' pilot samples, not its
// own, so the mean stays unbiased (4 standard errors of the image mean); the counts vary between pixels and stay within
// [pilot, spp]; the sample counts reported add up to the camera rays.
TEST(Integrator, AdaptiveSamplingUnbiasedInTheFurnace) {
  Material mat;
  mat.base_color = Spectrum(0.8);
  mat.emission = Spectrum(1.0, 0.5, 2.0);
  mat.double_sided = true;
  const SceneDesc d = make_scene({cube(0)}, {mat});
  RenderSettings adaptive;
  adaptive.noise_threshold = 0.05;
  adaptive.pilot_spp = 8;
  RenderStats st;
  const Image im = render(d, EnvironmentMap(), camera_at({0.1, 0.2, 0.3}, {0.3, -0.2, -1.0}, 70.0), 24, 16, 256, 1000,
                          0, &st, adaptive);
  const ImageStats s = stats_of(im);
  for (int c = 0; c < 3; ++c) {
    const double expected = mat.emission[c] / (1.0 - 0.8);
    EXPECT_NEAR(s.mean[c], expected, 4.0 * s.stderr_[c]) << "channel " << c;
  }
  ASSERT_EQ(st.pixel_samples.size(), 24u * 16u);
  std::uint64_t total = 0;
  std::uint32_t lo = 1u << 31, hi = 0;
  for (std::uint32_t n : st.pixel_samples) {
    total += n;
    lo = std::min(lo, n);
    hi = std::max(hi, n);
  }
  EXPECT_GE(lo, 8u);
  EXPECT_LE(hi, 256u);
  EXPECT_LT(lo, hi) << "the counts should follow the pixels' noise";
  EXPECT_EQ(st.pilot_samples, 24u * 16u * 8u);
  EXPECT_EQ(st.rays.camera, total);
}

// Adaptive sampling is deterministic for any thread count: counts and pixels bit for bit.
TEST(Integrator, AdaptiveSamplingDeterministicAcrossThreads) {
  const SceneDesc d = lit_box();
  const CameraDesc cam = camera_at({0.0, 0.0, 0.9}, {0.0, 0.0, -1.0}, 60.0);
  RenderSettings adaptive;
  adaptive.noise_threshold = 0.1;
  adaptive.pilot_spp = 4;
  RenderStats s1, s2;
  const Image a = render(d, EnvironmentMap(), cam, 40, 36, 64, 64, 1, &s1, adaptive);
  const Image b = render(d, EnvironmentMap(), cam, 40, 36, 64, 64, 2, &s2, adaptive);
  EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
  EXPECT_EQ(s1.pixel_samples, s2.pixel_samples);
}

// A time limit that is over at once: the first round (8 samples per pixel) still completes for
// every pixel, the render reports that the limit stopped it, and the image is that of 8 spp.
TEST(Integrator, TimeLimitKeepsTheFirstRound) {
  Material mat;
  mat.base_color = Spectrum(0.5);
  const SceneDesc d = make_scene({cube(0)}, {mat});
  RenderSettings limited;
  limited.time_limit = 1e-9;
  RenderStats st;
  const CameraDesc cam = camera_at({0.0, 0.0, 3.0}, {0.0, 0.0, -1.0}, 30.0);
  const EnvironmentMap env = EnvironmentMap::constant(Spectrum(1.0));
  const Image im = render(d, env, cam, 20, 20, 64, 1000, 0, &st, limited);
  EXPECT_TRUE(st.time_limit_reached);
  ASSERT_EQ(st.pixel_samples.size(), 400u);
  for (std::uint32_t n : st.pixel_samples) EXPECT_EQ(n, 8u);
  const Image eight = render(d, env, cam, 20, 20, 8);
  EXPECT_EQ(0, std::memcmp(im.rgb.data(), eight.rgb.data(), im.rgb.size() * sizeof(float)));
}

// Renders with AOVs (and optionally a crop, a preview callback) on the given settings.
Image render_full(const SceneDesc& desc, const EnvironmentMap& env, const CameraDesc& cam, RenderSettings s,
                  RenderAovs* aovs, RenderStats* stats = nullptr, const RenderProgress& progress = {}) {
  const Scene scene{SceneDesc(desc)};
  const LightSet lights(scene, env);
  const Camera camera(cam, s.width, s.height);
  RenderStats st;
  Image im = render_image(scene, lights, camera, s, &st, progress, aovs);
  EXPECT_EQ(st.invalid_samples, 0u);
  if (stats) *stats = st;
  return im;
}

RenderSettings settings_of(int w, int h, int spp) {
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.spp = spp;
  s.seed = 7;
  s.max_depth = 1000;
  return s;
}

// A Lambert plane y = 0 seen straight down from height 5: the albedo AOV is the base colour
// exactly (the cosine-sampled Lambert weight is the albedo), the normal is +Y, and the depth at
// a pixel is 5 / cos of its ray's angle to -Y (each sample's ray; the pixel averages them, so
// the centre pixel's depth lies within the spread of its footprint's rays).
TEST(IntegratorAovs, LambertPlaneAlbedoNormalDepth) {
  const Spectrum albedo(0.6, 0.3, 0.9);
  const SceneDesc d = lambert_plane(albedo);
  RenderSettings s = settings_of(9, 9, 16);
  s.aovs = AovSelection{true, true, true, false};
  RenderAovs aovs;
  render_full(d, EnvironmentMap::constant(Spectrum(1.0)), camera_at({0.0, 5.0, 0.0}, {0.0, -1.0, 0.0}, 40.0), s, &aovs);
  ASSERT_EQ(aovs.albedo.width, 9);
  ASSERT_EQ(aovs.depth.size(), 81u);
  EXPECT_TRUE(aovs.variance.rgb.empty());  // not asked for
  const double half = std::tan(20.0 * kPi / 180.0);
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 9; ++x) {
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(aovs.albedo.pixel(x, y)[c], albedo[c], 1e-6);
      EXPECT_NEAR(aovs.normal.pixel(x, y)[0], 0.0, 1e-6);
      EXPECT_NEAR(aovs.normal.pixel(x, y)[1], 1.0, 1e-6);
      EXPECT_NEAR(aovs.normal.pixel(x, y)[2], 0.0, 1e-6);
      // The pixel's rays span film offsets within one pixel of its centre (tent filter).
      auto depth_at = [&](double fx, double fy) {
        const double u = (2.0 * fx / 9.0 - 1.0) * half, v = (2.0 * fy / 9.0 - 1.0) * half;
        return 5.0 * std::sqrt(1.0 + u * u + v * v);
      };
      double lo = 1e300, hi = 0.0;
      for (double dx : {-0.5, 0.5, 1.5})
        for (double dy : {-0.5, 0.5, 1.5}) {
          lo = std::min(lo, depth_at(x + dx, y + dy));
          hi = std::max(hi, depth_at(x + dx, y + dy));
        }
      const double centre = depth_at(x + 0.5, y + 0.5);
      lo = std::min(lo, centre);
      EXPECT_GE(aovs.depth[static_cast<std::size_t>(y) * 9 + x], lo - 1e-6) << x << "," << y;
      EXPECT_LE(aovs.depth[static_cast<std::size_t>(y) * 9 + x], hi + 1e-6) << x << "," << y;
    }
}

// Rays that miss every surface leave albedo, normal and depth at 0.
TEST(IntegratorAovs, MissesAreZero) {
  Material mat;
  const SceneDesc d = make_scene({cube(0)}, {mat});
  RenderSettings s = settings_of(8, 8, 4);
  s.aovs = AovSelection{true, true, true, true};
  RenderAovs aovs;
  render_full(d, EnvironmentMap::constant(Spectrum(0.5)), camera_at({0.0, 0.0, 30.0}, {0.0, 1.0, 0.0}, 10.0), s, &aovs);
  for (std::size_t i = 0; i < 64; ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(aovs.albedo.rgb[i * 3 + c], 0.0f);
      EXPECT_EQ(aovs.normal.rgb[i * 3 + c], 0.0f);
      EXPECT_EQ(aovs.variance.rgb[i * 3 + c], 0.0f);  // the environment alone: no noise
    }
    EXPECT_EQ(aovs.depth[i], 0.0f);
  }
}

// The variance AOV is each pixel's estimate of the variance of its mean. In the emissive furnace
// every pixel is an independent estimate of the same radiance, so the spread of the pixel values
// over the image estimates the same variance independently: the two must agree. With N = 1024
// pixels the sample variance of the pixel values has a relative standard error of about
// sqrt(2 / (N - 1)) = 4.4 % (for near-normal pixel means); the AOV's mean over the pixels is far
// tighter. We allow 4 of those standard errors, 18 %: the variance of the samples instead of the
// mean's would be spp times too large. And the AOV must fall as 1/spp from 16 to 64 spp (the
// ratio's relative error is about 5 %; we allow 20 %).
TEST(IntegratorAovs, VarianceOfTheMeanMatchesThePixelSpread) {
  Material mat;
  mat.base_color = Spectrum(0.6);
  mat.emission = Spectrum(1.0, 0.5, 2.0);
  mat.double_sided = true;
  const SceneDesc d = make_scene({cube(0)}, {mat});
  const CameraDesc cam = camera_at({0.1, 0.2, 0.3}, {0.3, -0.2, -1.0}, 70.0);
  double mean_aov[2][3] = {};
  int k = 0;
  for (int spp : {16, 64}) {
    RenderSettings s = settings_of(32, 32, spp);
    s.aovs.variance = true;
    RenderAovs aovs;
    const Image im = render_full(d, EnvironmentMap(), cam, s, &aovs);
    const ImageStats st = stats_of(im);
    const double n = 32.0 * 32.0;
    for (int c = 0; c < 3; ++c) {
      double sum = 0.0;
      for (std::size_t i = 0; i < 1024; ++i) sum += aovs.variance.rgb[i * 3 + c];
      mean_aov[k][c] = sum / n;
      const double spread = st.stderr_[c] * st.stderr_[c] * n;  // sample variance of the pixel values
      EXPECT_NEAR(mean_aov[k][c], spread, 4.0 * std::sqrt(2.0 / (n - 1.0)) * spread) << "spp " << spp << " channel " << c;
    }
    ++k;
  }
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean_aov[0][c] / mean_aov[1][c], 4.0, 4.0 * 0.2) << "channel " << c;
}

// A lit Cornell-like box with an area light: every output of a crop equals the same region of the
// full image bit for bit, with uniform and with adaptive sampling (whose plan near the crop's
// edge needs the neighbours outside it), AOVs included.
TEST(IntegratorCrop, EqualsTheRegionOfTheFullImage) {
  const SceneDesc d = lit_box();
  const CameraDesc cam = camera_at({0.0, 0.0, 0.9}, {0.0, 0.0, -1.0}, 60.0);
  for (bool adaptive : {false, true}) {
    RenderSettings s = settings_of(40, 36, 24);
    s.aovs = AovSelection{true, true, true, true};
    if (adaptive) {
      s.noise_threshold = 0.1;
      s.pilot_spp = 4;
    }
    RenderAovs full_aovs, crop_aovs;
    RenderStats full_stats, crop_stats;
    const Image full = render_full(d, EnvironmentMap(), cam, s, &full_aovs, &full_stats);
    s.crop = PixelRegion{5, 17, 29, 36};  // touches the bottom edge, crosses tiles
    const Image crop = render_full(d, EnvironmentMap(), cam, s, &crop_aovs, &crop_stats);
    ASSERT_EQ(crop.width, 24);
    ASSERT_EQ(crop.height, 19);
    for (int y = 0; y < crop.height; ++y)
      for (int x = 0; x < crop.width; ++x) {
        const int fx = x + 5, fy = y + 17;
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(crop.pixel(x, y)[c], full.pixel(fx, fy)[c]) << adaptive << " " << x << "," << y;
          ASSERT_EQ(crop_aovs.albedo.pixel(x, y)[c], full_aovs.albedo.pixel(fx, fy)[c]);
          ASSERT_EQ(crop_aovs.normal.pixel(x, y)[c], full_aovs.normal.pixel(fx, fy)[c]);
          ASSERT_EQ(crop_aovs.variance.pixel(x, y)[c], full_aovs.variance.pixel(fx, fy)[c]);
        }
        ASSERT_EQ(crop_aovs.depth[static_cast<std::size_t>(y) * 24 + x], full_aovs.depth[static_cast<std::size_t>(fy) * 40 + fx]);
        if (adaptive) {
          ASSERT_EQ(crop_stats.pixel_samples[static_cast<std::size_t>(y) * 24 + x],
                    full_stats.pixel_samples[static_cast<std::size_t>(fy) * 40 + fx]);
        }
      }
  }
}

// Previews: rendering in rounds to call the preview gives the same image as one pass, and the
// previews come with growing sample counts, each image the mean of the samples so far.
TEST(IntegratorPreview, PreviewsDoNotChangeTheImage) {
  Material mat;
  mat.base_color = Spectrum(0.5);
  const SceneDesc d = make_scene({cube(0)}, {mat});
  const CameraDesc cam = camera_at({0.0, 0.0, 3.0}, {0.0, 0.0, -1.0}, 30.0);
  const EnvironmentMap env = EnvironmentMap::constant(Spectrum(1.0));
  RenderSettings s = settings_of(20, 20, 40);
  RenderAovs none;
  const Image once = render_full(d, env, cam, s, &none);
  s.preview_every = 1e-9;  // after every round
  std::vector<std::uint64_t> samples;
  RenderProgress progress;
  progress.preview = [&](const Image& so_far, std::uint64_t n) {
    EXPECT_EQ(so_far.width, 20);
    samples.push_back(n);
  };
  RenderStats st;
  const Image rounds = render_full(d, env, cam, s, &none, &st, progress);
  EXPECT_EQ(0, std::memcmp(once.rgb.data(), rounds.rgb.data(), once.rgb.size() * sizeof(float)));
  EXPECT_TRUE(st.pixel_samples.empty());  // previews alone add no sample-count channel
  // Rounds of 8 samples: previews after 8, 16, 24 and 32 (not after the last round, 40).
  EXPECT_EQ(samples, (std::vector<std::uint64_t>{400 * 8, 400 * 16, 400 * 24, 400 * 32}));
}

// Cancelling: a render of one 4x4 tile at 2^20 spp (minutes) stops within a path of each
// worker once the flag is set, and throws; a flag that stays clear changes no bit of the image.
TEST(IntegratorCancel, StopsWithinATileAndChangesNothingOtherwise) {
  Material mat;
  mat.base_color = Spectrum(0.5);
  const SceneDesc d = make_scene({cube(0)}, {mat});
  const CameraDesc cam = camera_at({0.0, 0.0, 3.0}, {0.0, 0.0, -1.0}, 30.0);
  const EnvironmentMap env = EnvironmentMap::constant(Spectrum(1.0));
  RenderAovs none;
  std::atomic<bool> cancel{false};
  RenderProgress progress;
  progress.cancel = &cancel;
  RenderSettings small = settings_of(20, 20, 16);
  const Image plain = render_full(d, env, cam, small, &none);
  const Image watched = render_full(d, env, cam, small, &none, nullptr, progress);
  EXPECT_EQ(0, std::memcmp(plain.rgb.data(), watched.rgb.data(), plain.rgb.size() * sizeof(float)));

  std::atomic<std::uint64_t> tiles_done{0};
  progress.advance = [&](std::uint64_t) { ++tiles_done; };
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    cancel = true;
  });
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(render_full(d, env, cam, settings_of(4, 4, 1 << 20), &none, nullptr, progress), RenderCancelled);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stopper.join();
  EXPECT_EQ(tiles_done.load(), 0u);  // stopped inside its only tile
  EXPECT_LT(seconds, 10.0);          // 0.2 s and one path per worker, not minutes
}

// --clamp (biased): a clamp above every sample changes no bit; a clamp below them scales each
// sample down to it, keeping its hue, and counts them. The Lambert plane under a directional
// light has zero-variance samples L = a E cos(theta) / pi.
TEST(IntegratorClamp, ScalesSamplesAboveItAndNothingElse) {
  const Spectrum albedo(0.6, 0.3, 0.9);
  SceneDesc d = lambert_plane(albedo);
  LightDesc sun;
  sun.type = LightType::kDirectional;
  sun.intensity = Spectrum(2.0);
  sun.direction = glm::dvec3(0.0, -1.0, 0.0);
  d.lights.push_back(sun);
  const CameraDesc cam = camera_at({0.0, 5.0, 0.0}, {0.0, -1.0, 0.0}, 40.0);
  RenderAovs none;
  RenderStats plain_stats, high_stats, low_stats;
  RenderSettings s = settings_of(8, 8, 4);
  const Image plain = render_full(d, EnvironmentMap(), cam, s, &none, &plain_stats);
  const double top = 0.9 * 2.0 / kPi;  // the blue channel, the largest
  s.clamp = 1.01 * top;
  const Image high = render_full(d, EnvironmentMap(), cam, s, &none, &high_stats);
  EXPECT_EQ(0, std::memcmp(plain.rgb.data(), high.rgb.data(), plain.rgb.size() * sizeof(float)));
  EXPECT_EQ(high_stats.clamped_samples, 0u);
  s.clamp = 0.5 * top;
  const Image low = render_full(d, EnvironmentMap(), cam, s, &none, &low_stats);
  EXPECT_EQ(low_stats.clamped_samples, 8u * 8u * 4u);
  for (std::size_t i = 0; i < low.rgb.size(); ++i) EXPECT_NEAR(low.rgb[i], 0.5 * plain.rgb[i], 1e-6);
}

// The tent filter sampler: the sample mean of x is 0 and E[x^2] = 1/6 for f(x) = 1 - |x|.
TEST(Integrator, TentFilterMoments) {
  const int n = 200000;
  double m1 = 0.0, m2 = 0.0;
  for (int i = 0; i < n; ++i) {
    Rng rng(1, i);
    const double x = sample_tent_filter({rng.uniform(), rng.uniform()}).x;
    ASSERT_LE(std::abs(x), 1.0);
    m1 += x;
    m2 += x * x;
  }
  m1 /= n;
  m2 /= n;
  // Var(x) = 1/6, Var(x^2) = E[x^4] - E[x^2]^2 = 1/15 - 1/36.
  EXPECT_NEAR(m1, 0.0, 4.0 * std::sqrt(1.0 / 6.0 / n));
  EXPECT_NEAR(m2, 1.0 / 6.0, 4.0 * std::sqrt((1.0 / 15.0 - 1.0 / 36.0) / n));
}

// Self-intersection offset: moves off the surface at any magnitude, by a few ulps only.
TEST(Integrator, RayOffsetScalesWithMagnitude) {
  for (double scale : {1e-3, 1.0, 1e3, 1e6}) {
    const glm::dvec3 p(scale, -scale, 0.5 * scale);
    const glm::dvec3 n(0.0, 0.0, 1.0);
    const glm::dvec3 o = offset_ray_origin(p, n);
    EXPECT_GT(o.z, static_cast<float>(p.z));
    EXPECT_LT(o.z - p.z, 1e-4 * scale + 1e-4);
    EXPECT_EQ(o.x, static_cast<float>(p.x));
  }
}

}  // namespace
}  // namespace lamina
