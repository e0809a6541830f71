// glTF read as authored (docs/rendering.md, "What is read from glTF"): every texture slot reads
// the TEXCOORD set its textureInfo names (or KHR_texture_transform's texCoord override), and each
// unsupported material extension is one warning naming the material and the extension.
#include <string>

#include <gtest/gtest.h>

#include "materials/base/sampling.h"
#include "renderer/image/image_io.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"
#include "tests/support/image_files.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using nlohmann::json;
using testing::GltfBuilder;
using testing::TempDir;

int count_warnings(const SceneDesc& s, const std::string& a, const std::string& b = "") {
  int n = 0;
  for (const std::string& w : s.warnings) n += w.find(a) != std::string::npos && w.find(b) != std::string::npos;
  return n;
}

// A quad z = 0 over [0, 1]^2 whose TEXCOORD_0 is (0.25, 0.5) and TEXCOORD_1 (0.75, 0.5) at
// every vertex, and a 2x1 texture: red on the left half (u < 0.5), green on the right. A slot
// reading set 1 sees green, set 0 red.
struct TwoSetQuad {
  TempDir dir{"gltf-texcoord1"};
  GltfBuilder b;
  json& j = b.json();
  TwoSetQuad() {
    Image im(2, 1);
    im.pixel(0, 0)[0] = 1.0f;
    im.pixel(1, 0)[1] = 1.0f;
    write_png(dir / "tex.png", im);
    j["images"] = {{{"uri", "tex.png"}}};
    j["samplers"] = {{{"wrapS", 33071}, {"wrapT", 33071}, {"magFilter", 9728}}};
    j["textures"] = {{{"source", 0}, {"sampler", 0}}};
  }
  // Adds the quad with material 0 and loads the file.
  SceneDesc load(bool with_set1 = true) {
    const int mesh = b.add_mesh({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {0, 1, 2, 0, 2, 3}, {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, 0);
    json& prim = j["meshes"][mesh]["primitives"][0];
    prim["attributes"]["TEXCOORD_0"] = b.add_floats({0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f}, 2);
    if (with_set1) prim["attributes"]["TEXCOORD_1"] = b.add_floats({0.75f, 0.5f, 0.75f, 0.5f, 0.75f, 0.5f, 0.75f, 0.5f}, 2);
    b.add_node({{"mesh", mesh}});
    b.write_gltf(dir / "q.gltf");
    return load_gltf(dir / "q.gltf");
  }
};

// Every texture slot: the set of its textureInfo; the hit carries both sets; the lookup through
// texture_uv sees the texture at TEXCOORD_1.
TEST(GltfAsAuthored, EveryTextureSlotReadsItsTexCoordSet) {
  TwoSetQuad q;
  const json one = {{"index", 0}, {"texCoord", 1}};
  q.j["materials"].push_back({{"name", "m"},
                              {"pbrMetallicRoughness", {{"baseColorTexture", one}, {"metallicRoughnessTexture", one}}},
                              {"normalTexture", one},
                              {"emissiveTexture", one},
                              {"emissiveFactor", {1.0, 1.0, 1.0}}});
  const SceneDesc desc = q.load();
  const Material& m = desc.materials.at(0);
  EXPECT_EQ(m.base_color_uv.set, 1);
  EXPECT_EQ(m.metallic_roughness_uv.set, 1);
  EXPECT_EQ(m.normal_uv.set, 1);
  EXPECT_EQ(m.emissive_uv.set, 1);
  EXPECT_EQ(count_warnings(desc, "TEXCOORD"), 0);
  Scene scene{SceneDesc(desc)};
  SurfaceHit hit;
  RayCounters counters;
  ASSERT_TRUE(scene.intersect(Ray{{0.3, 0.6, 1.0}, {0.0, 0.0, -1.0}}, &hit, counters));
  EXPECT_NEAR(hit.uv.x, 0.25, 1e-6);
  EXPECT_NEAR(hit.uv1.x, 0.75, 1e-6);
  const Texture& t = scene.desc().textures.at(m.base_color_texture);
  const Spectrum c = t.lookup(texture_uv(m.base_color_uv, hit));
  EXPECT_NEAR(c[0], 0.0, 1e-6);
  EXPECT_NEAR(c[1], 1.0, 1e-6);
  const Spectrum e = t.lookup(texture_uv(m.emissive_uv, hit));
  EXPECT_NEAR(e[1], 1.0, 1e-6);
}

// KHR_texture_transform's texCoord overrides the textureInfo's (the extension's README); a set
// beyond 1 is a warning naming the material and the slot, and reads set 0.
TEST(GltfAsAuthored, TextureTransformTexCoordOverridesAndHighSetsWarn) {
  TwoSetQuad q;
  q.j["extensionsUsed"] = {"KHR_texture_transform"};
  q.j["materials"].push_back(
      {{"name", "m"},
       {"pbrMetallicRoughness",
        {{"baseColorTexture", {{"index", 0}, {"extensions", {{"KHR_texture_transform", {{"texCoord", 1}}}}}}},
         {"metallicRoughnessTexture", {{"index", 0}, {"texCoord", 3}}}}}});
  const SceneDesc desc = q.load();
  EXPECT_EQ(desc.materials.at(0).base_color_uv.set, 1);
  EXPECT_EQ(desc.materials.at(0).metallic_roughness_uv.set, 0);
  EXPECT_EQ(count_warnings(desc, "material 'm': metallicRoughnessTexture reads TEXCOORD_3"), 1);
}

// A material that reads TEXCOORD_1 on a mesh without it: one warning naming both.
TEST(GltfAsAuthored, MissingTexCoord1IsAWarningNamingMeshAndMaterial) {
  TwoSetQuad q;
  q.j["materials"].push_back({{"name", "m"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}, {"texCoord", 1}}}}}});
  q.j["meshes"] = json::array();
  const SceneDesc desc = q.load(false);
  EXPECT_EQ(count_warnings(desc, "material 'm'", "TEXCOORD_1"), 1);
}

// Alpha coverage of a MASK material reads the base colour texture's set: alpha 0 on the left
// half of the texture (set 0), 1 on the right (set 1).
TEST(GltfAsAuthored, AlphaCoverageReadsTheBaseColourSet) {
  for (int set = 0; set < 2; ++set) {
    TwoSetQuad q;
    test::write_png8(q.dir / "tex.png", 2, 1, 4, {255, 255, 255, 0, 255, 255, 255, 255});  // alpha 0 | 1
    q.j["materials"].push_back({{"name", "m"},
                                {"alphaMode", "MASK"},
                                {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}, {"texCoord", set}}}}}});
    const SceneDesc desc = q.load();
    Scene scene{SceneDesc(desc)};
    EXPECT_DOUBLE_EQ(scene.coverage(0, 0, 0.2, 0.2), set == 1 ? 1.0 : 0.0) << "set " << set;
  }
}

// One warning per material and unsupported extension, naming both; a supported one is silent.
TEST(GltfAsAuthored, UnsupportedMaterialExtensionsWarnOncePerMaterial) {
  TwoSetQuad q;
  q.j["extensionsUsed"] = {"KHR_materials_sheen", "KHR_materials_clearcoat", "KHR_materials_ior"};
  q.j["materials"].push_back({{"name", "velvet"},
                              {"extensions", {{"KHR_materials_sheen", json::object()}, {"KHR_materials_ior", {{"ior", 1.4}}}}}});
  q.j["materials"].push_back({{"name", "car paint"},
                              {"extensions", {{"KHR_materials_sheen", json::object()}, {"KHR_materials_clearcoat", json::object()}}}});
  const SceneDesc desc = q.load();
  EXPECT_EQ(count_warnings(desc, "material 'velvet'", "KHR_materials_sheen"), 1);
  EXPECT_EQ(count_warnings(desc, "material 'car paint'", "KHR_materials_sheen"), 1);
  EXPECT_EQ(count_warnings(desc, "material 'car paint'", "KHR_materials_clearcoat"), 1);
  EXPECT_EQ(count_warnings(desc, "KHR_materials_ior"), 0);
  EXPECT_EQ(count_warnings(desc, "KHR_materials_sheen"), 2);  // not listed again for the file
}

// Blender's exporter writes a P-watt point light as P / (4 pi) x 683 "cd" and a sun of S W/m^2
// as 683 S "lux" (io_scene_gltf2/blender/exp/lights.py, "Standard" lighting mode): read back
// as W/sr and W/m^2 once its generator is recognised, with one warning; other files as written.
TEST(GltfAsAuthored, BlenderLightsAreConvertedBackToWatts) {
  for (const std::string generator : {"Khronos glTF Blender I/O v4.1.63", "some other exporter"}) {
    TempDir dir("gltf-blender-lights");
    GltfBuilder b;
    json& j = b.json();
    j["asset"]["generator"] = generator;
    j["extensionsUsed"] = {"KHR_lights_punctual"};
    const double watts = 100.0, sun = 2.0;
    j["extensions"]["KHR_lights_punctual"]["lights"] = {
        {{"name", "bulb"}, {"type", "point"}, {"intensity", watts / (4.0 * kPi) * 683.0}},
        {{"name", "sun"}, {"type", "directional"}, {"intensity", sun * 683.0}}};
    b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0})}});
    b.add_node({{"translation", {0, 0, 3}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    b.add_node({{"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
    b.write_gltf(dir / "l.gltf");
    const SceneDesc s = load_gltf(dir / "l.gltf");
    ASSERT_EQ(s.lights.size(), 2u);
    const bool blender = generator.find("Blender") != std::string::npos;
    const double scale = blender ? 1.0 / 683.0 : 1.0;
    EXPECT_NEAR(s.lights[0].intensity[1], watts / (4.0 * kPi) * 683.0 * scale, 1e-9) << generator;
    EXPECT_NEAR(s.lights[1].intensity[1], sun * 683.0 * scale, 1e-9) << generator;
    EXPECT_EQ(count_warnings(s, "exported by Blender", "683"), blender ? 1 : 0);
  }
}

}  // namespace
}  // namespace lamina
