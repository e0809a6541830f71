// The spectral mode of the renderer (RenderSettings::spectral; docs/spectral.md, "Spectral
// rendering") against the RGB mode and closed forms. Tolerances as in test_integrator.cpp: the
// image mean of N independent pixels has standard error s / sqrt(N); two renders' means are
// compared within 3 standard errors of their difference, sqrt(se_a^2 + se_b^2).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "materials/adding_doubling/spectral_totals.h"
#include "materials/spectral/colour.h"
#include "materials/spectral/sampled_wavelengths.h"
#include "materials/stack/stack_file.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/render/film.h"
#include "renderer/render/render_request_check.h"
#include "tests/materials/spectral/colour_quadrature.h"
#include "tests/renderer/render_fixtures.h"

namespace lamina {
namespace {

using test::add_quad;
using test::camera_at;
using test::cube;
using test::lambert_plane;
using test::ImageStats;
using test::make_scene;
using test::stats_of;

Image render(const SceneDesc& desc, const EnvironmentMap& env, const CameraDesc& cam, int w, int h, int spp, bool spectral,
             int threads = 0) {
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.spp = spp;
  s.seed = 11;
  s.threads = threads;
  s.spectral = spectral;
  return test::render_valid(Scene{SceneDesc(desc)}, env, cam, s);
}

void expect_same_mean(const Image& rgb, const Image& spectral, const char* what) {
  const ImageStats a = stats_of(rgb), b = stats_of(spectral);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(b.mean[c], a.mean[c], 3.0 * std::hypot(a.stderr_[c], b.stderr_[c]) + 1e-9)
        << what << ", channel " << c << ": RGB " << a.mean[c] << " +- " << a.stderr_[c] << ", spectral " << b.mean[c]
        << " +- " << b.stderr_[c];
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

// ---- A flat chromophore slab against adding-doubling per wavelength ----

// A two-layer skin by chromophores (docs/spectral.md's skin_spectral.json, with blood's bands and
// melanin's slope in the visible), smooth top, semi-infinite dermis.
const char* kSkin = R"({"lamina_material": 1, "layers": [
    {"ior": 1.4, "thickness": 0.1, "chromophores": {"melanin": 0.05, "baseline": 0.5,
     "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}},
    {"ior": 1.4, "thickness": "inf", "chromophores": {"blood": 0.02, "oxygenation": 0.75, "water": 0.6, "baseline": 0.38,
     "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}}]})";

// The colour of a reflectance spectrum given on `nm` (read linearly between) under D65, as the
// renderer integrates it (colour_quadrature.h).
Spectrum colour_of(const std::vector<double>& nm, const std::vector<double>& r) {
  const TabulatedSpectrum refl(nm, r);
  return test::colour_by_quadrature([&](double l) { return refl(l); });
}

// The slab under a uniform white environment (Le = 1: D65 of luminance 1), seen at 35 degrees:
// every pixel's radiance is the directional albedo at the view, which by reciprocity is the
// total reflectance R_specular + R_diffuse for light incident at 35 degrees (no transmission).
// Reference: adding-doubling per wavelength (what `lamina brdf --wavelengths` prints) every
// 2 nm, its colour integrated as the renderer's film integrates. Tolerance: 3 standard errors of
// the image mean, plus the solver's own discretisation error (its N against N/2 estimate, as a
// colour) and the 2-nm grid's interpolation (its difference from a 4-nm grid's colour).
TEST(SpectralRender, FlatChromophoreSlabAgreesWithAddingDoublingPerWavelength) {
  const SpectralStack spectral = parse_spectral_stack_json(kSkin, "skin");
  LayeredBindings b;
  b.by_material.push_back(std::make_shared<const LayeredMaterial>(parse_stack_json(kSkin, "skin"), "skin"));
  LayeredShading layered;
  layered.bindings = &b;
  layered.spectral = {std::make_shared<const SpectralStack>(spectral)};
  const double theta = 35.0;
  RenderSettings s;
  s.width = s.height = 32;
  s.spp = 16;
  s.seed = 5;
  s.layered = &layered;
  s.spectral = true;
  const ImageStats rendered = stats_of(test::render_valid(Scene{make_scene({test::slab_plane(0)})}, EnvironmentMap::constant(Spectrum(1.0)),
                                                          test::camera_towards(test::world_dir(theta, 0.0)), s));

  const double mu = std::cos(theta * kPi / 180.0);
  auto reference = [&](double step, Spectrum* error) {
    const SpectralTotals t = adding_doubling_spectrum(spectral, WavelengthGrid::from_to(kSpectralFirstNm, kSpectralLastNm, step), mu);
    std::vector<double> r, e;
    for (const AddingDoublingEstimate& est : t.estimates) {
      r.push_back(est.totals.R_specular[0] + est.totals.R_diffuse[0]);
      e.push_back(est.error.R_specular[0] + est.error.R_diffuse[0]);
    }
    if (error) *error = colour_of(t.nm, e);
    return colour_of(t.nm, r);
  };
  Spectrum solver_error;
  const Spectrum expected = reference(2.0, &solver_error), coarser = reference(4.0, nullptr);
  for (int c = 0; c < 3; ++c) {
    const double tol = 3.0 * rendered.stderr_[c] + std::abs(solver_error[c]) + std::abs(expected[c] - coarser[c]);
    if (std::getenv("LAMINA_TEST_VERBOSE"))
      std::printf("channel %d: rendered %g +- %g, adding-doubling %g (solver error %g, grid %g)\n", c, rendered.mean[c],
                  rendered.stderr_[c], expected[c], solver_error[c], expected[c] - coarser[c]);
    EXPECT_NEAR(rendered.mean[c], expected[c], tol)
        << "channel " << c << ": rendered " << rendered.mean[c] << " +- " << rendered.stderr_[c] << ", adding-doubling "
        << expected[c] << " (solver error " << solver_error[c] << ", grid " << expected[c] - coarser[c] << ")";
  }
}

// A chromophore layer bound to a map (docs/stack_bindings.md) in the spectral mode: a plane whose
// melanin map has two constant halves (melanin 0.01 where u < 0.5, 0.3 beyond) renders, at each
// half, as the same plane given that melanin in its file, within 3 standard errors of the two
// image means' difference. The map is 4 x 1 texels, so around u = 0.25 and 0.75 its bilinear
// lookup reads one half's value alone. The two melanins differ by far more than the errors, so a
// binding that were ignored (or applied to the other half) fails.
TEST(SpectralRender, MelaninMapHalvesRenderAsTheirConstantMelanin) {
  // The file with that melanin, its baseline giving way as a bound fraction's does.
  auto skin_with = [](double melanin) {
    std::string t = kSkin;
    const std::string key = "\"melanin\": 0.05, \"baseline\": 0.5";
    t.replace(t.find(key), key.size(),
              "\"melanin\": " + std::to_string(melanin) + ", \"baseline\": " + std::to_string(0.5 - (melanin - 0.05)));
    return t;
  };
  Mesh plane;
  plane.material = 0;
  add_quad(&plane, {-1000, 0, 1000}, {1000, 0, 1000}, {1000, 0, -1000}, {-1000, 0, -1000});
  plane.texcoords = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // u = (x + 1000) / 2000
  SceneDesc desc = make_scene({plane});
  Texture tex;
  tex.width = 4;
  tex.height = 1;
  for (int k : {0, 0, 1, 1})
    for (int c = 0; c < 3; ++c) tex.rgb.push_back(static_cast<float>(k));
  desc.textures.push_back(tex);
  desc.gltf_textures[0] = static_cast<int>(desc.textures.size()) - 1;
  auto t = std::make_shared<const StackTemplate>(parse_stack_template_json(kSkin, "skin"));
  const nlohmann::json spec = nlohmann::json::parse(R"({"bind": [{"parameter": "layers[0].chromophores.melanin",
      "texture": 0, "channel": "r", "range": [0.01, 0.3]}]})");
  auto bound = std::make_shared<const StackBindings>(spec, t, desc, "scene.gltf", "skin", "scene.gltf");
  const Scene scene{SceneDesc(desc)};
  const EnvironmentMap env = EnvironmentMap::constant(Spectrum(1.0));
  auto render_at = [&](double x, const std::shared_ptr<const LayeredMaterial>& m, const SpectralStack& spectral) {
    LayeredBindings b;
    b.by_material.push_back(m);
    LayeredShading layered;
    layered.bindings = &b;
    layered.spectral = {std::make_shared<const SpectralStack>(spectral)};
    CameraDesc cam = test::camera_towards(test::world_dir(35.0, 0.0));
    cam.position += glm::dvec3(x, 0.0, 0.0);
    RenderSettings s;
    s.width = s.height = 24;
    s.spp = 8;
    s.seed = 9;
    s.layered = &layered;
    s.spectral = true;
    return test::render_valid(scene, env, cam, s);
  };
  const SpectralStack spectral = parse_spectral_stack_json(kSkin, "skin");
  const auto mapped = std::make_shared<const LayeredMaterial>(t->stack, "skin", bound);
  for (const auto& [x, melanin] : {std::pair{-500.0, 0.01}, std::pair{500.0, 0.3}}) {
    const std::string file = skin_with(melanin);
    const auto given = std::make_shared<const LayeredMaterial>(parse_stack_json(file, "skin"), "skin");
    const Image a = render_at(x, mapped, spectral), b = render_at(x, given, parse_spectral_stack_json(file, "skin"));
    expect_same_mean(b, a, melanin < 0.1 ? "melanin 0.01 half" : "melanin 0.3 half");
  }
  // The halves differ (the test can tell a binding from none).
  const ImageStats light = stats_of(render_at(-500.0, mapped, spectral)), dark = stats_of(render_at(500.0, mapped, spectral));
  EXPECT_GT(light.mean[0] - dark.mean[0], 10.0 * std::hypot(light.stderr_[0], dark.stderr_[0]));
}

// Every --subsurface mode renders spectrally (the table and lambert modes on a wavelength grid:
// test_spectral_tables.cpp; first-order's closed form on the stack at the path's wavelengths),
// so the request's rules are the RGB mode's: the walk's options only where a walk runs. What the
// spectral mode still refuses is the material's business (chromophores bound to maps in the table
// and lambert modes: test_spectral_modes_cli.cpp).
TEST(SpectralRender, AcceptsEverySubsurfaceMode) {
  for (const char* mode : {"table", "first-order", "lambert", "auto", "random-walk"}) {
    RenderRequest r;
    r.settings.spectral = true;
    r.given = {"--spectral", "--subsurface"};
    ASSERT_TRUE(parse_subsurface_choice(mode, &r.subsurface));
    r.subsurface.tolerance = 0.05;
    EXPECT_NO_THROW(check_render_request(r)) << mode;
    r.given.push_back("--guiding");
    const bool walks = r.subsurface.automatic || r.subsurface.mode == SubsurfaceMode::RandomWalk;
    if (walks) EXPECT_NO_THROW(check_render_request(r)) << mode;
    else EXPECT_THROW(check_render_request(r), RenderRequestError) << mode;
  }
}

}  // namespace
}  // namespace lamina
