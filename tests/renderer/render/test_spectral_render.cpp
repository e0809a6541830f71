// The spectral mode of the renderer (RenderSettings::spectral; docs/spectral.md, "Spectral
// rendering") against the RGB mode and closed forms. Tolerances as in test_integrator.cpp: the
// image mean of N independent pixels has standard error s / sqrt(N); two renders' means are
// compared within 3 standard errors of their difference, sqrt(se_a^2 + se_b^2).
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "renderer/render/film.h"
#include "renderer/render/render_request_check.h"
#include "tests/renderer/render_fixtures.h"

namespace lamina {
namespace {

using test::add_quad;
using test::cube;
using test::ImageStats;
using test::make_scene;
using test::stats_of;

CameraDesc camera_at(glm::dvec3 position, glm::dvec3 forward, double yfov_deg) {
  CameraDesc c;
  c.position = position;
  c.forward = forward;
  c.up = std::abs(forward.y) > 0.9 ? glm::dvec3(0.0, 0.0, -1.0) : glm::dvec3(0.0, 1.0, 0.0);
  c.yfov = yfov_deg * kPi / 180.0;
  return c;
}

Image render(const SceneDesc& desc, const EnvironmentMap& env, const CameraDesc& cam, int w, int h, int spp, bool spectral,
             int threads = 0) {
  const Scene scene{SceneDesc(desc)};
  const LightSet lights(scene, env);
  const Camera camera(cam, w, h);
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.spp = spp;
  s.seed = 11;
  s.threads = threads;
  s.spectral = spectral;
  RenderStats stats;
  Image im = render_image(scene, lights, camera, s, &stats);
  EXPECT_EQ(stats.invalid_samples, 0u);
  return im;
}

void expect_same_mean(const Image& rgb, const Image& spectral, const char* what) {
  const ImageStats a = stats_of(rgb), b = stats_of(spectral);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(b.mean[c], a.mean[c], 3.0 * std::hypot(a.stderr_[c], b.stderr_[c]) + 1e-9)
        << what << ", channel " << c << ": RGB " << a.mean[c] << " +- " << a.stderr_[c] << ", spectral " << b.mean[c]
        << " +- " << b.stderr_[c];
}

SceneDesc lambert_plane(const Spectrum& albedo) {
  Material mat;
  mat.base_color = albedo;
  Mesh plane;
  add_quad(&plane, {-100, 0, 100}, {100, 0, 100}, {100, 0, -100}, {-100, 0, -100});
  plane.material = 0;
  return make_scene({plane}, {mat});
}

LightDesc sun(double theta, double irradiance) {
  LightDesc l;
  l.type = LightType::kDirectional;
  l.intensity = Spectrum(irradiance);
  l.direction = glm::normalize(glm::dvec3(std::sin(theta), -std::cos(theta), 0.0));
  return l;
}

// A grey world, lit three ways (emissive walls with many bounces and Russian roulette, a
// uniform environment through light sampling and MIS, a delta light): the same mean in both
// modes. A grey reflectance uplifts to a flat spectrum and a grey emitter to D65, whose colour
// is white (to the 5-nm table's 1e-4, far below these errors).
TEST(SpectralRender, GreyWorldHasTheSameMeanInBothModes) {
  {
    Material mat;
    mat.base_color = Spectrum(0.6);
    mat.emission = Spectrum(1.5);
    mat.double_sided = true;
    const SceneDesc d = make_scene({cube(0)}, {mat});
    const CameraDesc cam = camera_at({0.1, 0.2, 0.3}, {0.3, -0.2, -1.0}, 70.0);
    expect_same_mean(render(d, EnvironmentMap(), cam, 24, 16, 16, false), render(d, EnvironmentMap(), cam, 24, 16, 16, true),
                     "emissive furnace");
  }
  {
    Material mat;
    mat.base_color = Spectrum(0.3);
    const SceneDesc d = make_scene({cube(0)}, {mat});
    const EnvironmentMap env = EnvironmentMap::constant(Spectrum(2.0));
    const CameraDesc cam = camera_at({0.0, 0.0, 3.0}, {0.0, 0.0, -1.0}, 10.0);
    expect_same_mean(render(d, env, cam, 16, 16, 16, false), render(d, env, cam, 16, 16, 16, true), "environment furnace");
  }
  {
    SceneDesc d = lambert_plane(Spectrum(0.45));
    d.lights.push_back(sun(kPi / 3.0, 2.0));
    const CameraDesc cam = camera_at({0.0, 5.0, 0.0}, {0.0, -1.0, 0.0}, 40.0);
    expect_same_mean(render(d, EnvironmentMap(), cam, 16, 16, 4, false), render(d, EnvironmentMap(), cam, 16, 16, 4, true),
                     "plane under a directional light");
  }
}

// A coloured Lambert plane under white directional light: the spectral image's mean is the
// albedo's colour times E cos / pi, within 3 standard errors and the uplift's colour error
// (SampledWavelengths.EstimatesTheColourOfASpectrum: 1.5e-3 of the albedo). Fails if the uplift,
// the film's XYZ or the light's D65 were wrong, or if a channel were carried unconverted.
TEST(SpectralRender, ColouredLambertUnderWhiteLight) {
  for (const Spectrum& albedo : {Spectrum(0.6, 0.3, 0.9), Spectrum(0.9, 0.1, 0.05)}) {
    SceneDesc d = lambert_plane(albedo);
    const double theta = kPi / 3.0, e = 2.0;
    d.lights.push_back(sun(theta, e));
    const Image im = render(d, EnvironmentMap(), camera_at({0.0, 5.0, 0.0}, {0.0, -1.0, 0.0}, 40.0), 16, 16, 8, true);
    const ImageStats s = stats_of(im);
    for (int c = 0; c < 3; ++c) {
      const double scale = e * std::cos(theta) / kPi;
      EXPECT_NEAR(s.mean[c], albedo[c] * scale, 3.0 * s.stderr_[c] + 1.5e-3 * scale) << "channel " << c;
      EXPECT_GT(s.stderr_[c], 0.0);  // the wavelengths vary: the mode is on
    }
  }
}

// Same seed, same image, for 1 and 2 threads (and tiles that divide the image differently).
TEST(SpectralRender, DeterministicAcrossThreadCounts) {
  Material wall;
  wall.base_color = Spectrum(0.7, 0.5, 0.3);
  Material lamp;
  lamp.emission = Spectrum(5.0, 4.0, 2.0);
  lamp.double_sided = true;
  Mesh light;
  add_quad(&light, {-0.3f, 0.99f, -0.3f}, {0.3f, 0.99f, -0.3f}, {0.3f, 0.99f, 0.3f}, {-0.3f, 0.99f, 0.3f});
  light.material = 1;
  const SceneDesc d = make_scene({cube(0), light}, {wall, lamp});
  const CameraDesc cam = camera_at({0.0, 0.0, 0.9}, {0.0, 0.0, -1.0}, 60.0);
  const Image a = render(d, EnvironmentMap(), cam, 41, 37, 3, true, 1);
  const Image b = render(d, EnvironmentMap(), cam, 41, 37, 3, true, 2);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
  const Image rgb = render(d, EnvironmentMap(), cam, 41, 37, 3, false, 1);
  EXPECT_NE(0, std::memcmp(a.rgb.data(), rgb.rgb.data(), a.rgb.size() * sizeof(float)));
}

// The options of layered materials are refused with --spectral, in one line naming both.
TEST(SpectralRender, RefusesTheOptionsOfLayeredMaterials) {
  for (const char* flag : {"--stack", "--materials", "--subsurface", "--table-method", "--cache", "--guiding"}) {
    RenderRequest r;
    r.settings.spectral = true;
    r.given = {"--spectral", flag};
    try {
      check_render_request(r);
      ADD_FAILURE() << flag << " accepted";
    } catch (const RenderRequestError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.find('\n'), std::string::npos);
      EXPECT_EQ(m.rfind(std::string(flag) + " is not meaningful with --spectral", 0), 0u) << m;
    }
  }
  RenderRequest plain;
  plain.settings.spectral = true;
  plain.given = {"--spectral", "--spp"};
  EXPECT_NO_THROW(check_render_request(plain));
}

}  // namespace
}  // namespace lamina
