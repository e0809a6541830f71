// glTF transmission, diffuse transmission, volume and IOR mapped onto a layered stack
// (renderer/layered/gltf_stack.h, docs/gltf_materials.md): the two relations it inverts, checked
// exactly and against the random walk; the mapping's coefficients from a glTF file; extras still
// winning; and a leaf of diffuse transmission rendering back-lit, which a Lambert surface cannot.
#include <algorithm>
#include <cmath>
#include <vector>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "materials/tables/albedo.h"
#include "materials/base/sampling.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/gltf_stack.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/material_binding.h"
#include "renderer/render/film.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/scene.h"
#include "tests/renderer/gltf_fixture.h"
#include "tests/renderer/render_fixtures.h"

namespace lamina {
namespace {

using nlohmann::json;
using test::stats_of;
using testing::GltfBuilder;
using testing::TempDir;

// van de Hulst's R(alpha) (isotropic, semi-infinite), the relation the inversion undoes.
double van_de_hulst(double alpha) {
  const double s = std::sqrt(1.0 - alpha);
  return (1.0 - s) * (1.0 - 0.139 * s) / (1.0 + 1.17 * s);
}

TEST(GltfStack, AlbedoInversionUndoesVanDeHulst) {
  EXPECT_NEAR(albedo_from_diffuse_reflectance(0.0), 0.0, 1e-12);
  EXPECT_NEAR(albedo_from_diffuse_reflectance(1.0), 1.0, 1e-12);
  for (double A = 0.05; A < 1.0; A += 0.05) {
    const double alpha = albedo_from_diffuse_reflectance(A);
    EXPECT_NEAR(van_de_hulst(alpha), A, 1e-12) << A;
  }
}

// The approximations against the exact transport (the random walk), index-matched slabs:
// - a semi-infinite isotropic medium of albedo albedo_from_diffuse_reflectance(A) reflects A
//   under diffuse light: van de Hulst's formula is an approximation, allowed 0.02 (its stated
//   accuracy is of order 1 %) plus 4 standard errors;
// - a non-absorbing slab of optical depth optical_depth_from_diffuse_transmittance(D) transmits
//   D (1 - R, since nothing is absorbed): the Eddington solution, allowed 0.03 plus 4 standard
//   errors (two-stream solutions are good to a few per cent for conservative slabs).
// Measured differences are printed (they are quoted in docs/gltf_materials.md).
TEST(GltfStack, RelationsAgreeWithTheRandomWalk) {
  const int walks = 1 << 14;
  for (double A : {0.2, 0.5, 0.8}) {
    const double alpha = albedo_from_diffuse_reflectance(A);
    LayerStack s;
    s.layers.push_back(make_layer("m", 1.0, kInfiniteThickness, Spectrum(1.0 - alpha), Spectrum(alpha), Spectrum(0.0)));
    Spectrum se;
    const Spectrum r = diffuse_bihemispherical_albedo(s, walks, 5, &se);
    std::printf("van de Hulst: A = %.2f, walk %.4f +- %.4f\n", A, r[0], se[0]);
    EXPECT_NEAR(r[0], A, 0.02 + 4.0 * se[0]) << A;
  }
  for (double D : {0.3, 0.5, 0.7}) {
    const double tau = optical_depth_from_diffuse_transmittance(D);
    LayerStack s;
    s.layers.push_back(make_layer("m", 1.0, 1.0, Spectrum(0.0), Spectrum(tau), Spectrum(0.0)));
    s.below.ior = 1.0;
    Spectrum se;
    const Spectrum r = diffuse_bihemispherical_albedo(s, walks, 6, &se);
    std::printf("Eddington: D = %.2f, walk 1 - R = %.4f +- %.4f\n", D, 1.0 - r[0], se[0]);
    EXPECT_NEAR(1.0 - r[0], D, 0.03 + 4.0 * se[0]) << D;
  }
}

// How far the mapped leaf (thin-walled, diffuse transmission D, index 1.5) reflects from what
// glTF's model gives, (1 - F_avg)(1 - D) A per channel, for docs/gltf_materials.md. A physical
// bound holds: the slab reflects less than the semi-infinite medium of the same albedo
// (A, up to van de Hulst's 0.001), since light also leaves through its back, and its Fresnel
// interfaces trap light that is then partly absorbed.
TEST(GltfStack, MappedLeafReflectanceAgainstTheGltfModel) {
  Material leaf;
  leaf.name = "leaf";
  leaf.base_color = Spectrum(0.22, 0.42, 0.08);
  leaf.transmissive.diffuse_transmission = true;
  leaf.transmissive.diffuse_transmission_factor = 0.45;
  const LayerStack stack = gltf_stack(leaf, "test");
  Spectrum se;
  const Spectrum r = diffuse_bihemispherical_albedo(stack, 1 << 14, 9, &se);
  for (int c = 0; c < 3; ++c) {
    // 0.092: the hemispherical (cosine-weighted) Fresnel reflectance of n = 1.5 from outside.
    std::printf("leaf channel %d: walk R %.4f +- %.4f, glTF (1 - 0.092)(1 - D) A = %.4f, A = %.2f\n", c, r[c], se[c],
                (1.0 - 0.092) * 0.55 * leaf.base_color[c], leaf.base_color[c]);
    EXPECT_LT(r[c], leaf.base_color[c] + 0.001 + 4.0 * se[c]) << c;
  }
}

// A glTF material with every extension, read and mapped: coefficients per the documented formulas.
TEST(GltfStack, ExtensionsMapOntoTheDocumentedCoefficients) {
  TempDir dir("gltf-stack");
  GltfBuilder b;
  json& j = b.json();
  j["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_ior",
                         "KHR_materials_diffuse_transmission"};
  j["materials"].push_back(
      {{"name", "jade"},
       {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.5, 0.2, 1.0}}}},
       {"extensions",
        {{"KHR_materials_transmission", {{"transmissionFactor", 0.6}}},
         {"KHR_materials_volume", {{"thicknessFactor", 0.002}, {"attenuationDistance", 0.01}, {"attenuationColor", {0.5, 0.25, 1.0}}}},
         {"KHR_materials_ior", {{"ior", 1.4}}}}}});
  j["materials"].push_back({{"name", "leaf"},
                            {"pbrMetallicRoughness", {{"baseColorFactor", {0.3, 0.5, 0.1, 1.0}}}},
                            {"extensions", {{"KHR_materials_diffuse_transmission", {{"diffuseTransmissionFactor", 0.4}}}}}});
  j["materials"].push_back({{"name", "glass_no_transmission"},
                            {"extensions", {{"KHR_materials_volume", {{"thicknessFactor", 0.01}}}, {"KHR_materials_ior", {{"ior", 1.5}}}}}});
  for (int m = 0; m < 3; ++m) b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, m)}});
  b.write_gltf(dir / "s.gltf");
  const SceneDesc desc = load_gltf(dir / "s.gltf");
  for (const std::string& w : desc.warnings) EXPECT_EQ(w.find("unsupported"), std::string::npos) << w;
  const LayeredBindings bound = bind_layered_materials(desc, "");
  ASSERT_NE(bound.get(0), nullptr);
  ASSERT_NE(bound.get(1), nullptr);
  EXPECT_EQ(bound.get(2), nullptr);  // volume without transmission: metallic-roughness, as glTF says

  const LayerStack& jade = bound.get(0)->base_stack();
  ASSERT_EQ(jade.layers.size(), 1u);
  const Layer& l = jade.layers[0];
  EXPECT_DOUBLE_EQ(l.ior, 1.4);
  EXPECT_DOUBLE_EQ(jade.above_ior, 1.0);
  EXPECT_EQ(jade.below.kind, Below::Kind::Dielectric);
  EXPECT_DOUBLE_EQ(jade.below.ior, 1.0);
  EXPECT_NEAR(l.thickness, 1.0, 1e-12);  // half of 0.002 m = 2 mm: a closed mesh is crossed twice
  const double tau = -std::log(0.6), d = 1.0;
  const double base[3] = {0.8, 0.5, 0.2}, att[3] = {0.5, 0.25, 1.0};
  for (int c = 0; c < 3; ++c) {
    const double alpha = albedo_from_diffuse_reflectance(base[c]);
    EXPECT_NEAR(l.sigma_s()[c], alpha * tau / d, 1e-12) << c;
    // Beer-Lambert over the attenuation distance of 10 mm, plus the scattering part's absorption.
    EXPECT_NEAR(l.sigma_a[c], (1.0 - alpha) * tau / d - std::log(att[c]) / 10.0, 1e-12) << c;
    EXPECT_DOUBLE_EQ(l.lobes[0].g[c], 0.0);
  }

  const LayerStack& leaf = bound.get(1)->base_stack();
  EXPECT_DOUBLE_EQ(leaf.layers[0].ior, 1.5);  // KHR_materials_ior's default
  EXPECT_DOUBLE_EQ(leaf.layers[0].thickness, kThinWallThicknessMm);
  EXPECT_NEAR(leaf.layers[0].sigma_t()[1] * kThinWallThicknessMm, (4.0 / 3.0) * (1.0 / 0.4 - 1.0), 1e-12);
  EXPECT_NEAR(leaf.layers[0].albedo()[1], albedo_from_diffuse_reflectance(0.5), 1e-12);
  EXPECT_TRUE(leaf.transmits());
}

// extras.lamina.stack still wins over the extensions; a value out of range is a one-line error.
TEST(GltfStack, ExtrasWinAndBadValuesAreErrors) {
  TempDir dir("gltf-stack-extras");
  std::ofstream(dir / "one.json") << R"({"lamina_material": 1, "name": "one", "layers": [
      {"name": "l", "ior": 1.33, "thickness": 0.5, "sigma_a": 0.1, "sigma_s": 2.0, "g": 0.0}], "below": {"ior": 1.0}})";
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "leaf"},
                                   {"extras", {{"lamina", {{"stack", "one.json"}}}}},
                                   {"extensions", {{"KHR_materials_diffuse_transmission", {{"diffuseTransmissionFactor", 0.4}}}}}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
  b.write_gltf(dir / "s.gltf");
  const LayeredBindings bound = bind_layered_materials(load_gltf(dir / "s.gltf"), "");
  ASSERT_NE(bound.get(0), nullptr);
  EXPECT_DOUBLE_EQ(bound.get(0)->base_stack().layers[0].ior, 1.33);

  GltfBuilder bad;
  bad.json()["materials"].push_back({{"name", "m"}, {"extensions", {{"KHR_materials_transmission", {{"transmissionFactor", 1.5}}}}}});
  bad.add_node({{"mesh", bad.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
  bad.write_gltf(dir / "bad.gltf");
  try {
    load_gltf(dir / "bad.gltf");
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(dir / "bad.gltf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("material 'm': extensions.KHR_materials_transmission.transmissionFactor: must be a number in [0, 1]"),
              std::string::npos)
        << msg;
  }
  // KHR_materials_ior 0 (the schema's minimum) loads; only a transmitting material refuses it.
  for (bool transmits : {false, true}) {
    GltfBuilder m;
    json ext = {{"KHR_materials_ior", {{"ior", 0.0}}}};
    if (transmits) ext["KHR_materials_transmission"] = {{"transmissionFactor", 0.5}};
    m.json()["materials"].push_back({{"name", "m"}, {"extensions", ext}});
    m.add_node({{"mesh", m.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
    m.write_gltf(dir / "ior.gltf");
    const SceneDesc desc = load_gltf(dir / "ior.gltf");
    if (!transmits) {
      EXPECT_EQ(bind_layered_materials(desc, "").get(0), nullptr);
      continue;
    }
    try {
      bind_layered_materials(desc, "");
      ADD_FAILURE() << "no error for ior 0 with transmission";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("material 'm': extensions.KHR_materials_ior.ior is below 1"), std::string::npos)
          << e.what();
    }
  }
}

// A thin-walled leaf (diffuse transmission 0.4, green base colour) lit from the front by a
// directional light of irradiance E: rendered (random walk) from behind, it glows with transmitted
// light, which no opaque BRDF can give (the metallic-roughness surface it would otherwise be is
// black from behind: checked too). Energy: the back's radiance is at most E / pi (all of E
// transmitted diffusely), and its mean is more than 10 standard errors above 0.
TEST(GltfStack, DiffuseTransmissionLeafRendersBackLit) {
  TempDir dir("gltf-stack-leaf");
  for (bool layered : {true, false}) {
    testing::write_leaf_square(dir / "leaf.gltf", layered);
    SceneDesc desc = load_gltf(dir / "leaf.gltf");
    LightDesc sun;
    sun.type = LightType::kDirectional;
    sun.intensity = Spectrum(3.0);
    sun.direction = {0.0, 0.0, -1.0};  // onto the front (+z) side
    desc.lights.push_back(sun);
    const LayeredBindings bound = bind_layered_materials(desc, "");
    EXPECT_EQ(bound.get(0) != nullptr, layered);
    const Scene scene{std::move(desc)};
    const LightSet lights(scene, EnvironmentMap());
    CameraDesc cam;
    cam.position = {0.0, 0.0, -4.0};
    cam.forward = {0.0, 0.0, 1.0};
    cam.yfov = 0.3;  // sees only the leaf
    const Camera camera(cam, 16, 16);
    LayeredShading shading;
    shading.bindings = &bound;
    RenderSettings s;
    s.width = s.height = 16;
    s.spp = 8;
    s.layered = &shading;
    const Image im = render_image(scene, lights, camera, s, nullptr);
    const auto st = stats_of(im);
    std::printf("leaf seen from behind (%s): mean %.4f %.4f %.4f (+- %.4f)\n", layered ? "layered" : "metallic-roughness",
                st.mean[0], st.mean[1], st.mean[2], st.stderr_[1]);
    if (layered) {
      EXPECT_GT(st.mean[1], 10.0 * st.stderr_[1]);
      EXPECT_LT(st.mean[1], 3.0 / kPi);
      EXPECT_GT(st.mean[1], st.mean[2]);  // green leaf, green light through it
    } else {
      EXPECT_EQ(st.mean[1], 0.0);
    }
  }
}

// The committed scene (scripts/make_gltf_leaf_scene.py): three alpha-masked cards with diffuse
// transmission, lit from the camera's side (front) and from behind (back), under a faint
// environment of 0.03. Pixels whose centre's camera ray meets no leaf (outside the outline, or
// through a hole) see the environment: 0.03 up to the tent filter's reach into a leaf edge, so
// their median is 0.03. Leaf pixels are lit: their mean green is more than 10 x what the
// environment alone could give them (0.03 x the base colour's green 0.42), front and back.
TEST(GltfStack, CommittedLeafSceneRendersFrontAndBackLit) {
  for (const char* side : {"front", "back"}) {
    const std::string path = std::string(LAMINA_SOURCE_DIR) + "/scenes/gltf_leaf/gltf_leaf_" + side + ".gltf";
    const SceneDesc desc = load_gltf(path);
    ASSERT_EQ(desc.materials.size(), 1u);
    EXPECT_EQ(desc.materials[0].alpha_mode, AlphaMode::kMask);
    const LayeredBindings bound = bind_layered_materials(desc, "");
    ASSERT_NE(bound.get(0), nullptr);
    const Scene scene{SceneDesc(desc)};
    const LightSet lights(scene, EnvironmentMap::constant(Spectrum(0.03)));
    const int w = 48, h = 36;
    const Camera camera(desc.cameras.at(0), w, h);
    LayeredShading shading;
    shading.bindings = &bound;
    RenderSettings s;
    s.width = w;
    s.height = h;
    s.spp = 8;
    s.layered = &shading;
    const Image im = render_image(scene, lights, camera, s, nullptr);
    std::vector<double> background;
    double leaf_green = 0.0;
    int leaf = 0;
    RayCounters counters;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        SurfaceHit hit;
        if (scene.intersect(camera.generate_ray({x + 0.5, y + 0.5}), &hit, counters)) {
          leaf_green += im.pixel(x, y)[1];
          ++leaf;
        } else {
          background.push_back(im.pixel(x, y)[1]);
        }
      }
    ASSERT_GT(leaf, 100) << side;
    ASSERT_GT(background.size(), 100u) << side;
    std::nth_element(background.begin(), background.begin() + background.size() / 2, background.end());
    EXPECT_NEAR(background[background.size() / 2], 0.03, 1e-6) << side;
    std::printf("%s: %d leaf pixels, mean green %.4f\n", side, leaf, leaf_green / leaf);
    EXPECT_GT(leaf_green / leaf, 10.0 * 0.03 * 0.42) << side;
  }
}

// KHR_materials_volume's thicknessTexture: its G channel t scales the layer's thickness,
// t x thicknessFactor / 2 (in mm), as a texture-driven parameter read at TEXCOORD_0; without it
// the stack has no bindings.
TEST(GltfStack, ThicknessTextureDrivesTheLayerThickness) {
  TempDir dir("gltf-thickness-texture");
  Image im(2, 1);
  im.pixel(1, 0)[1] = 1.0f;  // G: 0 on the left half, 1 on the right
  write_png(dir / "t.png", im);
  GltfBuilder b;
  json& j = b.json();
  j["images"] = {{{"uri", "t.png"}}};
  j["samplers"] = {{{"wrapS", 33071}, {"wrapT", 33071}}};
  j["textures"] = {{{"source", 0}, {"sampler", 0}}};
  j["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_volume"};
  json volume = {{"thicknessFactor", 0.004}, {"thicknessTexture", {{"index", 0}}}};
  j["materials"].push_back({{"name", "gel"},
                            {"extensions", {{"KHR_materials_transmission", {{"transmissionFactor", 0.5}}},
                                            {"KHR_materials_volume", volume}}}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
  b.write_gltf(dir / "g.gltf");
  const SceneDesc desc = load_gltf(dir / "g.gltf");
  EXPECT_EQ(desc.materials[0].transmissive.thickness_texture, 0);
  for (const std::string& w : desc.warnings) EXPECT_EQ(w.find("thicknessTexture"), std::string::npos) << w;
  const LayeredBindings bound = bind_layered_materials(desc, "");
  ASSERT_TRUE(bound.by_material[0]);
  const StackBindings* bindings = bound.by_material[0]->bindings();
  ASSERT_NE(bindings, nullptr);
  ASSERT_EQ(bindings->parameters().size(), 1u);
  const double full = 0.5 * 0.004 * kMillimetresPerSceneUnit;  // 2 mm: the factor's thickness
  EXPECT_DOUBLE_EQ(bound.by_material[0]->base_stack().layers[0].thickness, full);
  Spectrum v;
  bindings->values({0.25, 0.5}, &v);
  EXPECT_NEAR(v[0], 0.0, 1e-6);
  bindings->values({0.75, 0.5}, &v);
  EXPECT_NEAR(v[0], full, 1e-5);
  // Without the texture: the plain stack.
  j["materials"][0]["extensions"]["KHR_materials_volume"].erase("thicknessTexture");
  b.write_gltf(dir / "plain.gltf");
  const SceneDesc plain = load_gltf(dir / "plain.gltf");
  EXPECT_EQ(bind_layered_materials(plain, "").by_material[0]->bindings(), nullptr);
}

}  // namespace
}  // namespace lamina
