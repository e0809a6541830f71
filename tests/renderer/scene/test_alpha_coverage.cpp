// Alpha coverage (glTF 2.0 section 3.9.4): MASK cut-outs and BLEND as stochastic transparency,
// for camera rays, path continuation rays and shadow rays (renderer/scene/alpha_coverage.h).
// Scenes are built in code (their expected answers are exact) except the loader's own test,
// which writes a glTF with an RGBA texture.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "tests/support/image_files.h"
#include <gtest/gtest.h>

#include "materials/base/sampling.h"
#include "renderer/render/film.h"
#include "renderer/scene/alpha_coverage.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/scene.h"
#include "tests/renderer/gltf_fixture.h"
#include "tests/renderer/render_fixtures.h"

namespace lamina {
namespace {

using nlohmann::json;
using test::add_quad;
using test::make_scene;
using test::stats_of;
using testing::GltfBuilder;
using testing::TempDir;

// An 8-bit RGBA PNG (stb_image_write; Lamina's own write_png writes RGB only).
void write_rgba_png(const std::string& path, int w, int h, const std::vector<unsigned char>& rgba) {
  lamina::test::write_png8(path, w, h, 4, rgba);
}

// A texture of alpha values (colour white), row-major from the top row.
Texture alpha_texture(int w, int h, const std::vector<float>& alpha) {
  Texture t;
  t.width = w;
  t.height = h;
  t.rgb.assign(static_cast<std::size_t>(w) * h * 3, 1.0f);
  t.alpha = alpha;
  return t;
}

// The quad [-sx, sx] x [-sy, sy] at height z facing +z, with u = (x + sx) / (2 sx) and
// v = (sy - y) / (2 sy) (v down the image, as glTF).
Mesh uv_quad(float sx, float sy, float z, int material) {
  Mesh m;
  m.material = material;
  add_quad(&m, {-sx, -sy, z}, {sx, -sy, z}, {sx, sy, z}, {-sx, sy, z});
  m.texcoords = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  return m;
}

TEST(AlphaCoverage, LoaderReadsModesCutoffsAndAlphaChannels) {
  TempDir dir("gltf-alpha");
  // 4 x 1 texels, alpha 0, 64, 191, 255 (8-bit, linear: glTF's alpha is not sRGB-encoded).
  write_rgba_png(dir / "a.png", 4, 1, {255, 0, 0, 0, 255, 0, 0, 64, 255, 0, 0, 191, 255, 0, 0, 255});
  GltfBuilder b;
  json& j = b.json();
  j["images"] = {{{"uri", "a.png"}}};
  j["textures"] = {{{"source", 0}}};
  j["materials"].push_back({{"name", "leaf"}, {"alphaMode", "MASK"}, {"alphaCutoff", 0.3},
                            {"pbrMetallicRoughness", {{"baseColorFactor", {1.0, 1.0, 1.0, 0.8}}, {"baseColorTexture", {{"index", 0}}}}}});
  j["materials"].push_back({{"name", "veil"}, {"alphaMode", "BLEND"}});
  j["materials"].push_back({{"name", "solid"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
  const std::vector<float> quad = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
  for (int material = 0; material < 3; ++material) {
    const int mesh = b.add_mesh(quad, {0, 1, 2, 0, 2, 3}, {}, material);
    j["meshes"][mesh]["primitives"][0]["attributes"]["COLOR_0"] =
        b.add_floats({1, 1, 1, 0.25f, 1, 1, 1, 0.5f, 1, 1, 1, 0.75f, 1, 1, 1, 1}, 4);
    j["meshes"][mesh]["primitives"][0]["attributes"]["TEXCOORD_0"] = b.add_floats({0, 1, 1, 1, 1, 0, 0, 0}, 2);
    b.add_node({{"mesh", mesh}});
  }
  b.write_gltf(dir / "a.gltf");
  const SceneDesc s = load_gltf(dir / "a.gltf");
  ASSERT_EQ(s.materials.size(), 3u);
  EXPECT_EQ(s.materials[0].alpha_mode, AlphaMode::kMask);
  EXPECT_DOUBLE_EQ(s.materials[0].alpha_cutoff, 0.3);
  EXPECT_DOUBLE_EQ(s.materials[0].base_alpha, 0.8);
  EXPECT_EQ(s.materials[1].alpha_mode, AlphaMode::kBlend);
  EXPECT_DOUBLE_EQ(s.materials[1].alpha_cutoff, 0.5);  // the default
  EXPECT_EQ(s.materials[2].alpha_mode, AlphaMode::kOpaque);
  const Texture& tex = s.textures[s.materials[0].base_color_texture];
  ASSERT_EQ(tex.alpha.size(), 4u);
  EXPECT_FLOAT_EQ(tex.alpha[1], 64.0f / 255.0f);  // linear: no sRGB curve
  EXPECT_FLOAT_EQ(tex.alpha[2], 191.0f / 255.0f);
  EXPECT_FLOAT_EQ(tex.rgb[0], 1.0f);
  ASSERT_EQ(s.meshes.size(), 3u);
  EXPECT_EQ(s.meshes[0].colour_alphas, (std::vector<float>{0.25f, 0.5f, 0.75f, 1.0f}));
  EXPECT_TRUE(s.meshes[2].colour_alphas.empty());  // opaque: alpha never read
  // alpha at the centre of texel 2 (u = 5/8) of the first quad: 0.8 x 191/255 x COLOR_0's alpha
  // there (x = 0.25, y = 0: barycentric blend of the corners' 0.25, 0.5, 0.75).
  AlphaCoverage c{&s.meshes[0], &s.materials[0], &tex, 0};
  // Triangle 0 is (-1,-1) (1,-1) (1,1): barycentrics (0.375, 0.125, 0.5) are the point (0.25, 0).
  const double b1 = 0.125, b2 = 0.5, b0 = 1.0 - b1 - b2;
  const double x = -b0 + b1 + b2, u = (x + 1.0) / 2.0;
  ASSERT_NEAR(u, 5.0 / 8.0, 1e-12);
  const double vertex_alpha = b0 * 0.25 + b1 * 0.5 + b2 * 0.75;
  EXPECT_NEAR(coverage_alpha(c, 0, b1, b2), 0.8 * (191.0 / 255.0) * vertex_alpha, 1e-6);

  for (const auto& [key, value, what] : std::vector<std::tuple<std::string, json, std::string>>{
           {"alphaMode", "CUTOUT", "alphaMode 'CUTOUT' is not OPAQUE, MASK or BLEND"},
           {"alphaCutoff", -0.5, "alphaCutoff must be a finite number >= 0"}}) {
    GltfBuilder bad;
    bad.json()["materials"].push_back({{"name", "m"}, {key, value}});
    bad.add_node({{"mesh", bad.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
    bad.write_gltf(dir / "bad.gltf");
    try {
      load_gltf(dir / "bad.gltf");
      ADD_FAILURE() << "no error for " << key;
    } catch (const SceneError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(dir / "bad.gltf"), std::string::npos) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  }
}

// A MASK quad at z = 0 with a 4 x 4 checkerboard of alpha 0 and 1 over an opaque backdrop at
// z = -1: at every texel centre (where the bilinear lookup returns the texel itself) a camera
// ray from above meets the quad exactly where alpha is 1 and the backdrop elsewhere, and a
// shadow ray from between the two towards +z is blocked exactly where alpha is 1.
TEST(AlphaCoverage, MaskLetsCameraAndShadowRaysThroughCutOuts) {
  std::vector<float> checker(16);
  for (int i = 0; i < 16; ++i) checker[i] = static_cast<float>((i % 4 + i / 4) % 2);
  Material cutout;
  cutout.alpha_mode = AlphaMode::kMask;
  cutout.base_color_texture = 0;
  SceneDesc d = make_scene({uv_quad(1, 1, 0, 0), uv_quad(2, 2, -1, 1)}, {cutout, Material{}});
  d.textures.push_back(alpha_texture(4, 4, checker));
  const Scene scene{std::move(d)};
  RayCounters counters;
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col) {
      const double x = -1.0 + (col + 0.5) / 2.0, y = 1.0 - (row + 0.5) / 2.0;
      const bool opaque = checker[row * 4 + col] > 0.5f;
      SurfaceHit hit;
      ASSERT_TRUE(scene.intersect(Ray{{x, y, 1.0}, {0.0, 0.0, -1.0}}, &hit, counters));
      EXPECT_EQ(hit.mesh, opaque ? 0 : 1) << row << "," << col;
      EXPECT_NEAR(hit.t, opaque ? 1.0 : 2.0, 1e-5);
      EXPECT_EQ(scene.occluded(Ray{{x, y, -0.5}, {0.0, 0.0, 1.0}}, 1.0, counters), opaque) << row << "," << col;
    }
  // Without a texture: baseColorFactor's alpha against the cutoff (0.4 < 0.5 cut, 0.5 kept).
  for (double a : {0.4, 0.5}) {
    Material m;
    m.alpha_mode = AlphaMode::kMask;
    m.base_alpha = a;
    const Scene s{make_scene({uv_quad(1, 1, 0, 0)}, {m})};
    SurfaceHit hit;
    EXPECT_EQ(s.intersect(Ray{{0.1, 0.2, 1.0}, {0.0, 0.0, -1.0}}, &hit, counters), a >= 0.5) << a;
    EXPECT_EQ(s.occluded(Ray{{0.1, 0.2, 1.0}, {0.0, 0.0, -1.0}}, 2.0, counters), a >= 0.5) << a;
  }
}

// Pixel coverage of a cut-out in a rendered image: a black MASK quad filling an orthographic
// view (and taller than it), in front of a uniform environment of radiance 1, so the image's
// mean is the share of the view that is cut out. The alpha texture is 8 x 1 stripes
// 0 1 1 0 1 1 1 0 (repeat): between texel centres the bilinear alpha is linear, so a 1-1 interval
// is kept whole, a 0-0 interval not at all and a 0-1 interval over (1 - cutoff) of its length.
// Kept share: (3 + 4 (1 - cutoff)) / 8: 5/8 at cutoff 0.5, 3/4 at 0.25. The 4 edges fall on
// pixel borders (multiples of 1/32 in u, 64 pixels across); only the 2 columns each side of an
// edge that the tent filter (radius 1 pixel) reaches across it are random, each sample a
// Bernoulli of variance <= 1/4: the mean's standard error is at most
// sqrt(4 x 2 x 16 x 0.25 / spp) / 1024 (0.0014 at 16 spp), and we allow 4 of them.
TEST(AlphaCoverage, CutOutPixelCoverageMatchesTheAlphaPattern) {
  const std::vector<float> stripes = {0, 1, 1, 0, 1, 1, 1, 0};
  for (double cutoff : {0.5, 0.25}) {
    Material black;
    black.base_color = Spectrum(0.0);
    black.alpha_mode = AlphaMode::kMask;
    black.alpha_cutoff = cutoff;
    black.base_color_texture = 0;
    SceneDesc d = make_scene({uv_quad(1.0f, 0.5f, 0.0f, 0)}, {black});
    d.textures.push_back(alpha_texture(8, 1, stripes));
    const Scene scene{std::move(d)};
    const LightSet lights(scene, EnvironmentMap::constant(Spectrum(1.0)));
    CameraDesc cam;
    cam.position = {0.0, 0.0, 5.0};
    cam.orthographic = true;
    cam.ymag = 0.25;  // 64 x 16 pixels: half-width 1
    const Camera camera(cam, 64, 16);
    RenderSettings s;
    s.width = 64;
    s.height = 16;
    s.spp = 16;
    const Image im = render_image(scene, lights, camera, s, nullptr);
    const double kept = (3.0 + 4.0 * (1.0 - cutoff)) / 8.0;
    EXPECT_NEAR(stats_of(im).mean[0], 1.0 - kept, 4.0 * std::sqrt(4 * 2 * 16 * 0.25 / s.spp) / 1024.0)
        << "cutoff " << cutoff;
    // And pixel by pixel, where the tent filter stays inside one region: the first column
    // (u < 2/64, between texels 7 and 0, both alpha 0) is open, u around 0.2 (between the
    // centres of texels 1 and 2, both 1) is covered.
    EXPECT_NEAR(im.pixel(0, 8)[1], 1.0, 1e-6);
    EXPECT_NEAR(im.pixel(12, 8)[1], 0.0, 1e-6);
  }
}

// BLEND of alpha 0.3, straight through Scene: of N rays crossing the quad, the share that meets
// it (intersect) and the share that is blocked (occluded) are each 0.3 within 4 binomial
// standard errors sqrt(0.3 x 0.7 / N); the same ray always gives the same answer.
TEST(AlphaCoverage, BlendKeepsHitsWithProbabilityAlpha) {
  Material veil;
  veil.alpha_mode = AlphaMode::kBlend;
  veil.base_alpha = 0.3;
  const Scene scene{make_scene({uv_quad(1, 1, 0, 0)}, {veil})};
  RayCounters counters;
  Rng rng(1, 2);
  const int n = 20000;
  int hits = 0, blocked = 0;
  for (int i = 0; i < n; ++i) {
    const Ray r{{rng.uniform() - 0.5, rng.uniform() - 0.5, 1.0}, glm::normalize(glm::dvec3(0.1 * rng.uniform(), 0.0, -1.0))};
    SurfaceHit hit;
    const bool h = scene.intersect(r, &hit, counters);
    hits += h;
    EXPECT_EQ(h, scene.intersect(r, &hit, counters));
    blocked += scene.occluded(Ray{r.origin + 0.3 * r.direction, r.direction}, 10.0, counters);
  }
  const double se = std::sqrt(0.3 * 0.7 / n);
  EXPECT_NEAR(hits / double(n), 0.3, 4.0 * se);
  EXPECT_NEAR(blocked / double(n), 0.3, 4.0 * se);
}

// The integrator over a BLEND veil (black, alpha 0.3) at z = 1 above a Lambert floor (albedo a)
// at z = 0 lit straight down by a directional light E. Shadow rays cross the veil: the floor's
// radiance is 0.7 a E / pi (its bounce light leaves through the veil or dies on its black side).
// Seen from below the veil that is the image; seen from above, camera rays cross the veil too:
// 0.3 x 0 + 0.7 x 0.7 a E / pi. Each pixel is an independent estimate (its own camera rays, so
// its own hashes): within 4 standard errors of the image mean.
TEST(AlphaCoverage, BlendTransmitsOneMinusAlphaInTheImageAndInShadows) {
  Material veil;
  veil.base_color = Spectrum(0.0);
  veil.alpha_mode = AlphaMode::kBlend;
  veil.base_alpha = 0.3;
  Material floor;
  floor.base_color = Spectrum(0.5);
  SceneDesc d = make_scene({uv_quad(1000, 1000, 1, 0), uv_quad(1000, 1000, 0, 1)}, {veil, floor});
  LightDesc sun;
  sun.type = LightType::kDirectional;
  sun.intensity = Spectrum(1.0);
  sun.direction = {0.0, 0.0, -1.0};
  d.lights.push_back(sun);
  const Scene scene{std::move(d)};
  const LightSet lights(scene, EnvironmentMap());
  const double lit = 0.7 * 0.5 / kPi;
  for (double height : {0.5, 3.0}) {
    CameraDesc cam;
    cam.position = {0.0, 0.0, height};
    cam.forward = {0.0, 0.0, -1.0};
    cam.yfov = 0.5;
    const Camera camera(cam, 32, 32);
    RenderSettings s;
    s.width = s.height = 32;
    s.spp = 4;
    RenderStats stats;
    const Image im = render_image(scene, lights, camera, s, &stats);
    const auto st = stats_of(im);
    const double expected = height < 1.0 ? lit : 0.7 * lit;
    EXPECT_NEAR(st.mean[0], expected, 4.0 * st.stderr_[0]) << "camera at " << height;
    EXPECT_GT(st.stderr_[0], 0.0);  // stochastic: a zero here would mean the veil was ignored or solid
  }
}

// An alpha-cut emitter emits only where rays meet it, for light sampling as for BSDF-sampled
// rays that find it. A small emitting square (where light sampling carries nearly all of the MIS
// weight) of radiance Le and BLEND alpha 0.4 above a Lambert floor must light it as an opaque
// square of radiance 0.4 Le does (the two images' means within 4 standard errors); a MASK square
// whose alpha (0.3) is below the cutoff must not light it at all. Light sampling that ignored
// alpha would make the first 2.5x too bright and the second lit.
TEST(AlphaCoverage, CutOutEmittersEmitOnlyWhereRaysMeetThem) {
  auto render_floor = [](AlphaMode mode, double alpha, double le) {
    Material lamp;
    lamp.base_color = Spectrum(0.0);
    lamp.emission = Spectrum(le);
    lamp.double_sided = true;
    lamp.alpha_mode = mode;
    lamp.base_alpha = alpha;
    Material floor;
    floor.base_color = Spectrum(0.5);
    const SceneDesc d = make_scene({uv_quad(0.25f, 0.25f, 1, 0), uv_quad(1000, 1000, 0, 1)}, {lamp, floor});
    const Scene scene{SceneDesc(d)};
    const LightSet lights(scene, EnvironmentMap());
    CameraDesc cam;
    cam.position = {0.0, 0.0, 0.5};
    cam.forward = {0.0, 0.0, -1.0};
    cam.yfov = 0.5;
    const Camera camera(cam, 24, 24);
    RenderSettings s;
    s.width = s.height = 24;
    s.spp = 16;
    s.max_depth = 1;  // the floor's direct light only
    RenderStats stats;
    return render_image(scene, lights, camera, s, &stats);
  };
  const auto blend = stats_of(render_floor(AlphaMode::kBlend, 0.4, 2.0));
  const auto opaque = stats_of(render_floor(AlphaMode::kOpaque, 1.0, 0.8));
  EXPECT_GT(opaque.mean[0], 0.01);
  EXPECT_NEAR(blend.mean[0], opaque.mean[0], 4.0 * std::hypot(blend.stderr_[0], opaque.stderr_[0]));
  for (float v : render_floor(AlphaMode::kMask, 0.3, 2.0).rgb) ASSERT_EQ(v, 0.0f);
}

// Stochastic transparency is a hash of the ray, not a draw from a per-thread stream: the image of
// a BLEND scene is bit-identical for 1 and 2 threads.
TEST(AlphaCoverage, BlendIsDeterministicAcrossThreads) {
  Material veil;
  veil.base_color = Spectrum(0.2, 0.6, 0.3);
  veil.alpha_mode = AlphaMode::kBlend;
  veil.base_alpha = 0.5;
  const Scene scene{make_scene({uv_quad(1, 1, 0, 0), uv_quad(3, 3, -1, 1)}, {veil, Material{}})};
  const LightSet lights(scene, EnvironmentMap::constant(Spectrum(1.0)));
  CameraDesc cam;
  cam.position = {0.3, 0.2, 4.0};
  cam.forward = glm::normalize(glm::dvec3(-0.1, 0.0, -1.0));
  cam.yfov = 0.8;
  const Camera camera(cam, 24, 16);
  RenderSettings s;
  s.width = 24;
  s.height = 16;
  s.spp = 4;
  s.threads = 1;
  const Image one = render_image(scene, lights, camera, s, nullptr);
  s.threads = 2;
  const Image two = render_image(scene, lights, camera, s, nullptr);
  ASSERT_EQ(one.rgb.size(), two.rgb.size());
  EXPECT_EQ(0, std::memcmp(one.rgb.data(), two.rgb.data(), one.rgb.size() * sizeof(float)));
}

}  // namespace
}  // namespace lamina
