// The glTF loader on fixtures written here (known transforms, cameras, lights, materials, bad
// input) and on the Khronos sample files in the shared assets.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/stack/json_limits.h"
#include "materials/base/sampling.h"
#include "renderer/image/image_io.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/gltf_document.h"
#include "renderer/scene/gltf_validate.h"
#include "renderer/scene/scene_gltf.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using testing::GltfBuilder;
using testing::TempDir;
using nlohmann::json;

const std::vector<float> kTriangle = {0, 0, 0, 1, 0, 0, 0, 1, 0};

void expect_vec(const glm::dvec3& a, const glm::dvec3& b, double tol = 1e-6) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

// Expects load_gltf(path) to throw a one-line SceneError naming the file and containing `what`.
void expect_error(const std::string& path, const std::string& what) {
  try {
    load_gltf(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(SceneGltf, HierarchyWithTrsAndMatrix) {
  TempDir dir("gltf-trs");
  GltfBuilder b;
  const int mesh = b.add_mesh(kTriangle, {0, 1, 2}, {0, 0, 1, 0, 0, 1, 0, 0, 1});
  // Child: a column-major matrix translating by (0, 0, 1).
  const int child = b.add_node({{"mesh", mesh}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1}}}, false);
  // Parent: T (1,2,3) R (90 deg about +Y: quaternion (0, sin 45, 0, cos 45)) S 2.
  const double s45 = std::sqrt(0.5);
  b.add_node({{"children", {child}}, {"translation", {1, 2, 3}}, {"rotation", {0, s45, 0, s45}}, {"scale", {2, 2, 2}}});
  b.write_gltf(dir / "trs.gltf");
  const SceneDesc s = load_gltf(dir / "trs.gltf");
  ASSERT_EQ(s.meshes.size(), 1u);
  const Mesh& m = s.meshes[0];
  // By hand: child moves to z = 1; scale 2; Ry(90) maps (x, y, z) -> (z, y, -x); translate.
  expect_vec(glm::dvec3(m.positions[0]), {3, 2, 3}, 1e-5);
  expect_vec(glm::dvec3(m.positions[1]), {3, 2, 1}, 1e-5);
  expect_vec(glm::dvec3(m.positions[2]), {3, 4, 3}, 1e-5);
  ASSERT_EQ(m.normals.size(), 3u);
  expect_vec(glm::dvec3(m.normals[0]), {1, 0, 0}, 1e-6);
  expect_vec(s.bounds_min, {3, 2, 1}, 1e-5);
  expect_vec(s.bounds_max, {3, 4, 3}, 1e-5);
}

// Normals transform with the inverse transpose: under a non-uniform scale they stay
// perpendicular to the transformed face.
TEST(SceneGltf, NormalsUseInverseTranspose) {
  TempDir dir("gltf-normals");
  GltfBuilder b;
  const float r = static_cast<float>(std::sqrt(0.5));
  const int mesh = b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, -1}, {}, {0, r, r, 0, r, r, 0, r, r});
  b.add_node({{"mesh", mesh}, {"scale", {1, 4, 1}}});
  b.write_gltf(dir / "n.gltf");
  const SceneDesc s = load_gltf(dir / "n.gltf");
  const Mesh& m = s.meshes[0];
  const glm::dvec3 face = glm::normalize(glm::cross(glm::dvec3(m.positions[1] - m.positions[0]),
                                                    glm::dvec3(m.positions[2] - m.positions[0])));
  expect_vec(glm::dvec3(m.normals[0]), face, 1e-6);
  expect_vec(face, glm::normalize(glm::dvec3(0, 1, 4)), 1e-6);
}

TEST(SceneGltf, NonIndexedWithoutNormalsAndDegenerates) {
  TempDir dir("gltf-degenerate");
  GltfBuilder b;
  // One good triangle, one with three collinear points, one with a repeated vertex.
  const int mesh = b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 5, 5, 5, 5, 5, 5, 6, 5, 5});
  b.add_node({{"mesh", mesh}});
  const int lines = b.add_mesh(kTriangle, {0, 1}, {}, -1, 1);  // LINES: skipped
  b.add_node({{"mesh", lines}});
  b.write_glb(dir / "d.glb");
  const SceneDesc s = load_gltf(dir / "d.glb");
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.triangles, 1u);
  EXPECT_EQ(s.degenerate_triangles, 2u);
  EXPECT_TRUE(s.meshes[0].normals.empty());  // flat shading
  bool warned_lines = false, warned_degenerate = false;
  for (const std::string& w : s.warnings) {
    warned_lines |= w.find("points or lines") != std::string::npos;
    warned_degenerate |= w.find("2 degenerate") != std::string::npos;
  }
  EXPECT_TRUE(warned_lines);
  EXPECT_TRUE(warned_degenerate);
}

// Triangle strips and fans (glTF 2.0 section 3.7.2.1) become triangle lists with the winding the
// spec gives them: a unit square in z = 0 as a 4-vertex strip (non-indexed) and as a fan
// (indexed) gives two triangles each, both facing +z (counter-clockwise seen from +z), of total
// area 1; a strip of 2 vertices has no triangles (a warning, and no mesh).
TEST(SceneGltf, StripsAndFansBecomeTriangles) {
  TempDir dir("gltf-strips");
  GltfBuilder b;
  // Strip order: (0,0) (1,0) (0,1) (1,1); fan order around (0,0): (1,0) (1,1) (0,1).
  const int strip = b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, {}, {}, -1, 5);
  b.add_node({{"mesh", strip}});
  const int fan = b.add_mesh({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {0, 1, 2, 3}, {}, -1, 6);
  b.add_node({{"mesh", fan}, {"translation", {3.0, 0.0, 0.0}}});
  const int stub = b.add_mesh({0, 0, 0, 1, 0, 0}, {}, {}, -1, 5);
  b.add_node({{"mesh", stub}});
  b.write_gltf(dir / "s.gltf");
  const SceneDesc s = load_gltf(dir / "s.gltf");
  ASSERT_EQ(s.meshes.size(), 2u);  // the stub has no triangles: no mesh
  EXPECT_EQ(s.triangles, 4u);
  for (int m = 0; m < 2; ++m) {
    const Mesh& mesh = s.meshes[m];
    ASSERT_EQ(mesh.indices.size(), 6u) << m;
    double area = 0.0;
    for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
      const glm::dvec3 a = mesh.positions[mesh.indices[t]], b2 = mesh.positions[mesh.indices[t + 1]],
                       c = mesh.positions[mesh.indices[t + 2]];
      const glm::dvec3 n = glm::cross(b2 - a, c - a);
      EXPECT_GT(n.z, 0.0) << "mesh " << m << " triangle " << t / 3 << " is wound clockwise";
      area += 0.5 * glm::length(n);
    }
    EXPECT_NEAR(area, 1.0, 1e-6) << m;
  }
  bool warned = false;
  for (const std::string& w : s.warnings) warned |= w.find("fewer than 3 vertices") != std::string::npos;
  EXPECT_TRUE(warned);
}

// Orthographic cameras (glTF 2.0 section 3.10.3): the view is ymag high on each side of the axis
// (scaled by the node's scale along +Y) and ymag x the image's aspect wide; every ray runs along
// the camera's -Z from the camera's plane. A negative ymag is read as its magnitude (warned).
TEST(SceneGltf, OrthographicCamera) {
  TempDir dir("gltf-ortho");
  GltfBuilder b;
  const int mesh = b.add_mesh(kTriangle);
  b.add_node({{"mesh", mesh}});
  b.json()["cameras"] = {{{"type", "orthographic"}, {"name", "ortho"},
                          {"orthographic", {{"xmag", 3.0}, {"ymag", -1.5}, {"znear", 0.1}, {"zfar", 100.0}}}}};
  b.add_node({{"camera", 0}, {"translation", {0.0, 0.0, 5.0}}, {"scale", {2.0, 2.0, 2.0}}});
  b.write_gltf(dir / "o.gltf");
  const SceneDesc s = load_gltf(dir / "o.gltf");
  ASSERT_EQ(s.cameras.size(), 1u);
  const CameraDesc& c = s.cameras[0];
  EXPECT_TRUE(c.orthographic);
  EXPECT_DOUBLE_EQ(c.ymag, 3.0);  // |-1.5| x the node's scale 2
  bool warned = false;
  for (const std::string& w : s.warnings) warned |= w.find("negative orthographic ymag") != std::string::npos;
  EXPECT_TRUE(warned);
  const Camera camera(c, 200, 100);  // aspect 2: half-width 6
  const Ray corner = camera.generate_ray({0.0, 0.0}), centre = camera.generate_ray({100.0, 50.0});
  const Ray other = camera.generate_ray({200.0, 100.0});
  for (const Ray* r : {&corner, &centre, &other}) {
    EXPECT_NEAR(r->direction.x, 0.0, 1e-12);
    EXPECT_NEAR(r->direction.y, 0.0, 1e-12);
    EXPECT_NEAR(r->direction.z, -1.0, 1e-12);
    EXPECT_NEAR(r->origin.z, 5.0, 1e-9);
  }
  EXPECT_NEAR(centre.origin.x, 0.0, 1e-9);
  EXPECT_NEAR(centre.origin.y, 0.0, 1e-9);
  EXPECT_NEAR(corner.origin.x, -6.0, 1e-9);
  EXPECT_NEAR(corner.origin.y, 3.0, 1e-9);
  EXPECT_NEAR(other.origin.x, 6.0, 1e-9);
  EXPECT_NEAR(other.origin.y, -3.0, 1e-9);
}

TEST(SceneGltf, CamerasLightsAndMaterials) {
  TempDir dir("gltf-cam");
  GltfBuilder b;
  json& j = b.json();
  j["materials"].push_back({{"name", "glow"},
                            {"pbrMetallicRoughness", {{"baseColorFactor", {0.2, 0.4, 0.6, 1.0}}, {"metallicFactor", 0.0}}},
                            {"emissiveFactor", {1.0, 0.5, 0.0}},
                            {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}}},
                            {"extras", {{"lamina", {{"stack", "skin.json"}, {"scale", 2}}}}}});
  j["extensionsUsed"] = {"KHR_materials_emissive_strength", "KHR_lights_punctual", "KHR_materials_sheen"};
  const int mesh = b.add_mesh(kTriangle, {0, 1, 2}, {}, 0);
  b.add_node({{"mesh", mesh}});
  j["cameras"] = {{{"name", "main"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}},
                  {{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}}}}};
  const double s45 = std::sqrt(0.5);
  b.add_node({{"name", "cam0"}, {"camera", 0}, {"translation", {0, 0, 5}}});
  b.add_node({{"name", "sideNode"}, {"camera", 1}, {"translation", {5, 0, 0}}, {"rotation", {0, s45, 0, s45}}});
  j["extensions"]["KHR_lights_punctual"]["lights"] = {
      {{"name", "bulb"}, {"type", "point"}, {"color", {1.0, 0.5, 0.25}}, {"intensity", 10.0}},
      {{"name", "spot"}, {"type", "spot"}, {"intensity", 3.0}, {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.5}}}},
      {{"name", "sun"}, {"type", "directional"}, {"intensity", 2.0}}};
  b.add_node({{"translation", {1, 2, 3}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  // Rotated -90 degrees about X: local -Z (the light's direction) turns to -Y, straight down.
  b.add_node({{"translation", {0, 4, 0}}, {"rotation", {-s45, 0, 0, s45}}, {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
  b.add_node({{"rotation", {-s45, 0, 0, s45}}, {"extensions", {{"KHR_lights_punctual", {{"light", 2}}}}}});
  b.write_gltf(dir / "c.gltf");
  const SceneDesc s = load_gltf(dir / "c.gltf");

  ASSERT_EQ(s.cameras.size(), 2u);
  EXPECT_EQ(s.cameras[0].name, "main");
  expect_vec(s.cameras[0].position, {0, 0, 5});
  expect_vec(s.cameras[0].forward, {0, 0, -1});
  EXPECT_DOUBLE_EQ(s.cameras[0].yfov, 0.5);
  EXPECT_EQ(s.cameras[1].name, "sideNode");  // unnamed camera: its node's name
  expect_vec(s.cameras[1].position, {5, 0, 0});
  expect_vec(s.cameras[1].forward, {-1, 0, 0});  // Ry(90) maps -Z to -X
  expect_vec(s.cameras[1].up, {0, 1, 0});

  ASSERT_EQ(s.lights.size(), 3u);
  EXPECT_EQ(s.lights[0].type, LightType::kPoint);
  expect_vec(s.lights[0].position, {1, 2, 3});
  EXPECT_DOUBLE_EQ(s.lights[0].intensity[1], 5.0);
  EXPECT_DOUBLE_EQ(s.lights[0].intensity[2], 2.5);
  EXPECT_EQ(s.lights[1].type, LightType::kSpot);
  expect_vec(s.lights[1].direction, {0, -1, 0});
  EXPECT_DOUBLE_EQ(s.lights[1].cos_inner, std::cos(0.2));
  EXPECT_DOUBLE_EQ(s.lights[1].cos_outer, std::cos(0.5));
  EXPECT_EQ(s.lights[2].type, LightType::kDirectional);
  expect_vec(s.lights[2].direction, {0, -1, 0});
  EXPECT_DOUBLE_EQ(s.lights[2].intensity[0], 2.0);

  ASSERT_EQ(s.materials.size(), 1u);
  const Material& m = s.materials[0];
  EXPECT_DOUBLE_EQ(m.base_color[2], 0.6);
  EXPECT_DOUBLE_EQ(m.emission[0], 4.0);
  EXPECT_DOUBLE_EQ(m.emission[1], 2.0);
  EXPECT_DOUBLE_EQ(m.emission[2], 0.0);
  EXPECT_EQ(m.extras.at("lamina.stack"), "skin.json");
  EXPECT_EQ(m.extras.at("lamina.scale"), "2");
  int sheen_warnings = 0;
  for (const std::string& w : s.warnings) sheen_warnings += w.find("KHR_materials_sheen") != std::string::npos;
  EXPECT_EQ(sheen_warnings, 1);
}

// Base colour textures are decoded from sRGB; lookups at texel centres return the texel.
TEST(SceneGltf, TextureIsSrgbDecoded) {
  TempDir dir("gltf-tex");
  Image im(2, 1);
  im.pixel(0, 0)[0] = 0.5f;  // linear; the PNG stores it sRGB-encoded in 8 bits
  im.pixel(1, 0)[1] = 0.2f;
  write_png(dir / "tex.png", im);
  GltfBuilder b;
  json& j = b.json();
  j["images"] = {{{"uri", "tex.png"}}};
  j["samplers"] = {{{"wrapS", 33071}, {"wrapT", 33071}}};
  j["textures"] = {{{"source", 0}, {"sampler", 0}}};
  j["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
  b.add_node({{"mesh", b.add_mesh(kTriangle, {}, {}, 0)}});
  b.write_gltf(dir / "t.gltf");
  const SceneDesc s = load_gltf(dir / "t.gltf");
  ASSERT_EQ(s.textures.size(), 1u);
  const Spectrum left = s.textures[0].lookup({0.25, 0.5}), right = s.textures[0].lookup({0.75, 0.5});
  // 8-bit sRGB quantisation: half a code step is at most 0.5/255 * dL/dV <= 0.5/255 * 2.4 in linear.
  EXPECT_NEAR(left[0], 0.5, 0.5 / 255 * 2.4);
  EXPECT_NEAR(right[1], 0.2, 0.5 / 255 * 2.4);
  EXPECT_EQ(left[1], 0.0);
  std::filesystem::remove(dir / "tex.png");
  expect_error(dir / "t.gltf", "tex.png");
}

// Normal maps: the loader generates a tangent frame from the texture coordinates (T along +u,
// B up the image, i.e. along -v in glTF) and decodes the map linearly; a texel (0.75, 0.5, 1)
// tilts the normal towards +u, (0.5, 0.75, 1) towards the image's up (glTF 2.0 section 3.9.3:
// +X right, +Y up). The quad lies in z = 0 with u along +x and v along -y (image up = +y).
TEST(SceneGltf, NormalMapTiltsTowardsTheTangentFrame) {
  for (int axis = 0; axis < 2; ++axis) {
    TempDir dir("gltf-normal");
    Image im(1, 1);
    // write_png stores sRGB: pass the linear value whose encoding is the wanted 8-bit code.
    const auto stored = [](double code) { return static_cast<float>(std::pow((code / 255.0 + 0.055) / 1.055, 2.4)); };
    im.pixel(0, 0)[0] = stored(axis == 0 ? 191.0 : 128.0);
    im.pixel(0, 0)[1] = stored(axis == 1 ? 191.0 : 128.0);
    im.pixel(0, 0)[2] = 1.0f;
    write_png(dir / "n.png", im);
    GltfBuilder b;
    json& j = b.json();
    j["images"] = {{{"uri", "n.png"}}};
    j["textures"] = {{{"source", 0}}};
    j["materials"].push_back({{"normalTexture", {{"index", 0}}}});
    const int mesh = b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3},
                                {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, 0);
    j["meshes"][mesh]["primitives"][0]["attributes"]["TEXCOORD_0"] = b.add_floats({0, 1, 1, 1, 1, 0, 0, 0}, 2);
    b.add_node({{"mesh", mesh}});
    b.write_gltf(dir / "q.gltf");
    const SceneDesc s = load_gltf(dir / "q.gltf");
    ASSERT_EQ(s.meshes.size(), 1u);
    ASSERT_EQ(s.meshes[0].tangents.size(), 4u);
    for (const glm::vec4& t : s.meshes[0].tangents) {
      EXPECT_NEAR(t.x, 1.0, 1e-6);
      EXPECT_NEAR(t.w, 1.0, 0.0);  // B = cross(+z, +x) = +y: up the image
    }
    SurfaceHit hit;
    hit.ns = hit.ng = {0.0, 0.0, 1.0};
    hit.uv = {0.5, 0.5};
    hit.tangent = glm::dvec4(s.meshes[0].tangents[0]);
    const glm::dvec3 n = normal_mapped(hit, s.textures[s.materials[0].normal_texture], 1.0, hit.uv);
    const double tilt = (191.0 / 255.0) * 2.0 - 1.0;  // linear decoding: 0.498
    const glm::dvec3 expected = glm::normalize(axis == 0 ? glm::dvec3(tilt, 0.0, 1.0) : glm::dvec3(0.0, tilt, 1.0));
    EXPECT_NEAR(n.x, expected.x, 5e-3) << axis;
    EXPECT_NEAR(n.y, expected.y, 5e-3) << axis;
    EXPECT_NEAR(n.z, expected.z, 5e-3) << axis;
  }
}

// COLOR_0 is read per vertex (linear) and interpolated at hits; it multiplies the base colour in
// the renderer. A negative colour is an error naming the mesh.
TEST(SceneGltf, VertexColoursAreRead) {
  TempDir dir("gltf-colour");
  GltfBuilder b;
  const int mesh = b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3});
  b.json()["meshes"][mesh]["primitives"][0]["attributes"]["COLOR_0"] = b.add_floats({1, 0, 0, 0, 1, 0, 0, 0, 1, 0.5f, 0.5f, 0.5f}, 3);
  b.add_node({{"mesh", mesh}});
  b.write_gltf(dir / "c.gltf");
  const SceneDesc s = load_gltf(dir / "c.gltf");
  ASSERT_EQ(s.meshes.size(), 1u);
  ASSERT_EQ(s.meshes[0].colours.size(), 4u);
  EXPECT_EQ(s.meshes[0].colours[1], glm::vec3(0, 1, 0));
  EXPECT_EQ(s.meshes[0].colours[3], glm::vec3(0.5f));
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("COLOR_0"), std::string::npos) << w;
  Scene scene{SceneDesc(s)};
  SurfaceHit hit;
  RayCounters counters;
  // A ray down the quad's normal at (0.5, -0.5): inside triangle 0 (vertices 0, 1, 2).
  ASSERT_TRUE(scene.intersect(Ray{{0.5, -0.5, 1.0}, {0.0, 0.0, -1.0}}, &hit, counters));
  EXPECT_NEAR(hit.colour.x + hit.colour.y + hit.colour.z, 1.0, 1e-6);  // a blend of pure R, G, B
  EXPECT_GT(hit.colour.y, hit.colour.z);
  GltfBuilder bad;
  const int m2 = bad.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0});
  bad.json()["meshes"][m2]["primitives"][0]["attributes"]["COLOR_0"] = bad.add_floats({1, 0, 0, -1, 0, 0, 0, 0, 1}, 3);
  bad.add_node({{"mesh", m2}});
  bad.write_gltf(dir / "bad.gltf");
  expect_error(dir / "bad.gltf", "COLOR_0 of vertex 1");
}

// KHR_texture_transform (the ratified README's matrices): offset, then rotation (u' = cos u -
// sin v, v' = sin u + cos v), then scale, per textureInfo; a malformed one is an error naming
// the material, and the extension is no longer reported as unsupported.
TEST(SceneGltf, TextureTransformIsReadPerTexture) {
  TempDir dir("gltf-uvt");
  Image im(2, 1);
  write_png(dir / "tex.png", im);
  GltfBuilder b;
  json& j = b.json();
  j["images"] = {{{"uri", "tex.png"}}};
  j["textures"] = {{{"source", 0}}};
  j["extensionsUsed"] = {"KHR_texture_transform"};
  const json transform = {{"offset", {0.5, 0.25}}, {"rotation", kPi / 2}, {"scale", {2.0, 3.0}}};
  j["materials"].push_back({{"name", "m"},
                            {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}, {"extensions", {{"KHR_texture_transform", transform}}}}}}},
                            {"emissiveTexture", {{"index", 0}, {"extensions", {{"KHR_texture_transform", {{"offset", {0.1, 0.0}}}}}}}}});
  b.add_node({{"mesh", b.add_mesh(kTriangle, {}, {}, 0)}});
  b.write_gltf(dir / "t.gltf");
  const SceneDesc s = load_gltf(dir / "t.gltf");
  ASSERT_EQ(s.materials.size(), 1u);
  // (1, 0) scaled to (2, 0), rotated a quarter turn to (0, 2), offset to (0.5, 2.25).
  const glm::dvec2 p = s.materials[0].base_color_uv.apply({1.0, 0.0});
  EXPECT_NEAR(p.x, 0.5, 1e-12);
  EXPECT_NEAR(p.y, 2.25, 1e-12);
  // (0, 1) scaled to (0, 3), rotated to (-3, 0), offset to (-2.5, 0.25).
  const glm::dvec2 q = s.materials[0].base_color_uv.apply({0.0, 1.0});
  EXPECT_NEAR(q.x, -2.5, 1e-12);
  EXPECT_NEAR(q.y, 0.25, 1e-12);
  const glm::dvec2 e = s.materials[0].emissive_uv.apply({0.2, 0.3});
  EXPECT_NEAR(e.x, 0.3, 1e-12);
  EXPECT_NEAR(e.y, 0.3, 1e-12);
  EXPECT_EQ(s.materials[0].normal_uv.apply({0.2, 0.3}), glm::dvec2(0.2, 0.3));  // no transform: identity
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("KHR_texture_transform"), std::string::npos) << w;
  j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"]["scale"] = {1.0};
  b.write_gltf(dir / "bad.gltf");
  expect_error(dir / "bad.gltf", "material 'm': KHR_texture_transform.scale must be an array of 2 numbers");
}

TEST(SceneGltf, BadInputIsAOneLineError) {
  TempDir dir("gltf-bad");
  {  // NaN and infinite positions.
    GltfBuilder b;
    b.add_node({{"mesh", b.add_mesh({0, 0, 0, NAN, 0, 0, 0, 1, 0})}});
    b.write_gltf(dir / "nan.gltf");
    expect_error(dir / "nan.gltf", "non-finite vertex position");
    GltfBuilder c;
    c.add_node({{"mesh", c.add_mesh({0, 0, 0, INFINITY, 0, 0, 0, 1, 0})}});
    c.write_glb(dir / "inf.glb");
    expect_error(dir / "inf.glb", "non-finite vertex position");
  }
  {  // No geometry: a scene with a node but no mesh.
    GltfBuilder b;
    b.add_node({{"name", "empty"}});
    b.write_gltf(dir / "empty.gltf");
    expect_error(dir / "empty.gltf", "no triangles");
  }
  {  // A missing external buffer.
    GltfBuilder b;
    b.add_node({{"mesh", b.add_mesh(kTriangle)}});
    b.write_gltf(dir / "buf.gltf", "buf.bin");
    EXPECT_NO_THROW(load_gltf(dir / "buf.gltf"));
    std::filesystem::remove(dir / "buf.bin");
    expect_error(dir / "buf.gltf", "buf.bin");
  }
  {  // Truncated and corrupt .glb files.
    GltfBuilder b;
    b.add_node({{"mesh", b.add_mesh(kTriangle, {0, 1, 2})}});
    b.write_glb(dir / "ok.glb");
    std::ifstream in(dir / "ok.glb", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (std::size_t keep : {bytes.size() - 10, bytes.size() / 2, std::size_t{30}, std::size_t{5}}) {
      std::ofstream(dir / "cut.glb", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
      expect_error(dir / "cut.glb", "");
    }
    std::string corrupt = bytes;
    for (std::size_t i = 20; i < 60 && i < corrupt.size(); ++i) corrupt[i] = static_cast<char>(0xA5);
    std::ofstream(dir / "corrupt.glb", std::ios::binary).write(corrupt.data(), static_cast<std::streamsize>(corrupt.size()));
    expect_error(dir / "corrupt.glb", "");
  }
  {  // An index past the end of the vertices, and a file that does not exist.
    GltfBuilder b;
    b.add_node({{"mesh", b.add_mesh(kTriangle, {0, 1, 7})}});
    b.write_gltf(dir / "idx.gltf");
    expect_error(dir / "idx.gltf", "out of range");
    expect_error(dir / "nothing.gltf", "");
  }
}

// The nesting scanner every JSON reader runs before parsing (materials/stack/json_limits.h): levels
// are counted from 1 at the outermost bracket, and brackets in strings, escaped quotes
// included, do not count.
TEST(SceneGltf, JsonNestingScanner) {
  EXPECT_FALSE(json_nesting_exceeds("[[]]", 2));
  EXPECT_EQ(json_nesting_exceeds("[[]]", 1), std::optional<std::size_t>(1));
  EXPECT_FALSE(json_nesting_exceeds(std::string(512, '[') + std::string(512, ']')));
  EXPECT_EQ(json_nesting_exceeds(std::string(513, '[') + std::string(513, ']')), std::optional<std::size_t>(512));
  EXPECT_FALSE(json_nesting_exceeds(R"({"a": "[[[[{{{{"})", 1));
  // \" does not end the string, so the brackets after it are still inside it...
  EXPECT_FALSE(json_nesting_exceeds(R"(["\" [[[ \\\" [[["])", 1));
  // ...and \\ is a whole escape: the quote after it ends the string, and "[[" counts.
  EXPECT_EQ(json_nesting_exceeds(R"(["\\", [[1]]])", 2), std::optional<std::size_t>(8));
  // Closing brackets never make room: "]]]][[" is as deep as "[[".
  EXPECT_EQ(json_nesting_exceeds("]]]][[", 1), std::optional<std::size_t>(5));
  EXPECT_EQ(json_nesting_message(7), "JSON nested deeper than 512 levels (at byte 7)");
}

// Brackets and escapes inside strings are no nesting: a valid scene with thousands of them in
// its extras loads, and its extras survive.
TEST(SceneGltf, BracketsInStringsAreNotNesting) {
  TempDir dir("gltf-brackets");
  GltfBuilder b;
  std::string tricky;
  for (int i = 0; i < 1000; ++i) tricky += "[[{\"\\";
  b.json()["materials"].push_back({{"name", "m"}, {"extras", {{"note", tricky}}}});
  b.add_node({{"mesh", b.add_mesh(kTriangle, {}, {}, 0)}});
  b.write_gltf(dir / "b.gltf");
  const SceneDesc s = load_gltf(dir / "b.gltf");
  EXPECT_EQ(s.materials.at(0).extras.at("note"), tricky);
}

// The JSON-only reader (batch manifests check scenes with it) refuses deep JSON too, naming the
// byte of the file: in a .glb, past the 20 bytes of header and chunk header.
TEST(SceneGltf, DocumentReaderRefusesDeepJson) {
  TempDir dir("gltf-deep-doc");
  const std::string deep = R"({"asset": {"version": "2.0"}, "extras": )" + std::string(600, '[') + std::string(600, ']') + "}";
  std::ofstream(dir / "deep.gltf") << deep;
  const std::size_t at = deep.find('[') + 511;  // the root object is level 1
  try {
    read_gltf_json(dir / "deep.gltf");
    ADD_FAILURE() << "no error";
  } catch (const GltfDocumentError& e) {
    EXPECT_NE(std::string(e.what()).find("deep.gltf: JSON nested deeper than 512 levels (at byte " + std::to_string(at) + ")"),
              std::string::npos)
        << e.what();
  }
  expect_error(dir / "deep.gltf", "JSON nested deeper than 512 levels (at byte " + std::to_string(at) + ")");
  std::string chunk = deep;
  while (chunk.size() % 4) chunk += ' ';
  std::string glb = "glTF";
  auto u32 = [&glb](std::uint32_t v) { for (int i = 0; i < 4; ++i) glb += static_cast<char>((v >> (8 * i)) & 0xFF); };
  u32(2);
  u32(static_cast<std::uint32_t>(20 + chunk.size()));
  u32(static_cast<std::uint32_t>(chunk.size()));
  u32(0x4E4F534A);  // "JSON"
  glb += chunk;
  std::ofstream(dir / "deep.glb", std::ios::binary) << glb;
  expect_error(dir / "deep.glb", "JSON nested deeper than 512 levels (at byte " + std::to_string(20 + at) + ")");
}

// The memory estimate's limit, 8 GiB unless LAMINA_MAX_SCENE_BYTES says otherwise; a value that
// is not a positive whole number is an error naming the variable.
TEST(SceneGltf, SceneMemoryLimitFromTheEnvironment) {
  TempDir dir("gltf-limit");
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh(kTriangle, {0, 1, 2})}});
  b.write_gltf(dir / "t.gltf");
  EXPECT_EQ(max_scene_bytes(), kDefaultMaxSceneBytes);
  EXPECT_NO_THROW(load_gltf(dir / "t.gltf"));
  ::setenv("LAMINA_MAX_SCENE_BYTES", "100", 1);
  expect_error(dir / "t.gltf", "more than the limit of 100 bytes (LAMINA_MAX_SCENE_BYTES)");
  ::setenv("LAMINA_MAX_SCENE_BYTES", "1000000", 1);
  EXPECT_NO_THROW(load_gltf(dir / "t.gltf"));
  for (const char* bad : {"", "0", "-5", "8GiB", "1e9", "99999999999999999999999"}) {
    ::setenv("LAMINA_MAX_SCENE_BYTES", bad, 1);
    try {
      load_gltf(dir / "t.gltf");
      ADD_FAILURE() << "no error for '" << bad << "'";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("LAMINA_MAX_SCENE_BYTES"), std::string::npos) << e.what();
    }
  }
  ::unsetenv("LAMINA_MAX_SCENE_BYTES");
}

// The checks that need world transforms leave unusual but valid scenes alone: a camera whose
// own tiny scale cancels its parent's huge one, and a quaternion far off unit length (its
// squared length underflows), load.
TEST(SceneGltf, LargeButFiniteTransformsLoad) {
  TempDir dir("gltf-large");
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh(kTriangle)}, {"rotation", {0, 0, 0, 1e-200}}});
  b.json()["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 3.1}, {"znear", 0.1}, {"aspectRatio", 1.5}}}}};
  const int cam = b.add_node({{"camera", 0}, {"scale", {1e-150, 1e-150, 1e-150}}, {"translation", {0, 0, 5e-100}}}, false);
  b.add_node({{"children", {cam}}, {"scale", {1e100, 1e100, 1e100}}});
  b.write_gltf(dir / "l.gltf");
  const SceneDesc s = load_gltf(dir / "l.gltf");
  ASSERT_EQ(s.cameras.size(), 1u);
  expect_vec(s.cameras[0].forward, {0, 0, -1});
  expect_vec(s.cameras[0].up, {0, 1, 0});
  expect_vec(s.cameras[0].position, {0, 0, 5}, 1e-9);
  expect_vec(glm::dvec3(s.meshes.at(0).positions[1]), {1, 0, 0});
}

// Real files written elsewhere (Khronos glTF-Sample-Models, see the assets README).
// A spot light whose inner and outer cone angles are equal (Blender's exporter writes that for a
// spot blend of 0) loads as a hard-edged cone; an inverted one is refused (tests/corpus).
TEST(SceneGltf, SpotWithEqualConeAnglesLoads) {
  TempDir dir("gltf-spot-equal");
  GltfBuilder b;
  json& j = b.json();
  b.add_node({{"mesh", b.add_mesh(kTriangle, {0, 1, 2})}});
  j["extensionsUsed"] = {"KHR_lights_punctual"};
  j["extensions"]["KHR_lights_punctual"]["lights"] = {
      {{"type", "spot"}, {"intensity", 3.0}, {"spot", {{"innerConeAngle", 0.4}, {"outerConeAngle", 0.4}}}}};
  b.add_node({{"translation", {0, 0, 4}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  b.write_gltf(dir / "s.gltf");
  const SceneDesc s = load_gltf(dir / "s.gltf");
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].cos_inner, s.lights[0].cos_outer);
}

// A light or emission finite as a double but beyond float radiance would write Inf pixels: the
// strength (colour x intensity, emissiveFactor x emissiveStrength, largest channel) is at most
// kMaxLightStrength, refused above it with the JSON path and the limit; at the limit it loads.
TEST(SceneGltf, LightStrengthIsAtMostTheLimit) {
  TempDir dir("gltf-strength");
  auto write = [&](const std::string& name, const json& light, const json& material) {
    GltfBuilder b;
    json& j = b.json();
    j["materials"].push_back(material);
    j["extensionsUsed"] = {"KHR_materials_emissive_strength", "KHR_lights_punctual"};
    b.add_node({{"mesh", b.add_mesh(kTriangle, {0, 1, 2}, {}, 0)}});
    j["extensions"]["KHR_lights_punctual"]["lights"] = {light};
    b.add_node({{"translation", {0, 0, 4}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    b.write_gltf(dir / name);
    return dir / name;
  };
  const json point = {{"type", "point"}, {"intensity", 10.0}}, plain = {{"name", "plain"}};
  const json glow = {{"name", "glow"},
                     {"emissiveFactor", {1.0, 0.5, kMaxLightStrength}},
                     {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 1.0}}}}}};
  const SceneDesc at_limit = load_gltf(write("limit.gltf", {{"type", "point"}, {"intensity", kMaxLightStrength}}, glow));
  EXPECT_EQ(at_limit.lights[0].intensity[0], kMaxLightStrength);
  EXPECT_EQ(at_limit.materials[0].emission[2], kMaxLightStrength);
  expect_error(write("i.gltf", {{"type", "point"}, {"intensity", 1e300}}, plain),
               "extensions.KHR_lights_punctual.lights[0]: color x intensity is 1e+300, above the largest light "
               "strength, 1e+20");
  expect_error(write("c.gltf", {{"type", "directional"}, {"color", {1.0, 3e20, 1.0}}}, plain),
               "lights[0]: color x intensity is 3e+20, above the largest light strength");
  expect_error(write("ci.gltf", {{"type", "spot"}, {"color", {1e200, 1.0, 1.0}}, {"intensity", 1e200}}, plain),
               "lights[0]: color x intensity is inf, above the largest light strength");
  json strong = glow;
  strong["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = 1.5;
  expect_error(write("e.gltf", point, strong),
               "materials[0]: emissiveFactor x emissiveStrength is 1.5e+20, above the largest light strength");
  json factor = {{"name", "hot"}, {"emissiveFactor", {1e39, 0.0, 0.0}}};
  expect_error(write("f.gltf", point, factor), "materials[0]: emissiveFactor x emissiveStrength is 1e+39");
}

// Morph targets at their default weights (glTF 2.0 section 3.7.2.2): POSITION, NORMAL and
// TANGENT displacements weighted and added in the mesh's local space, before the node transform;
// the node's weights override the mesh's; without weights every weight is 0; a weight count
// different from the target count is an error naming the mesh.
TEST(SceneGltf, MorphTargetsAtDefaultWeights) {
  TempDir dir("gltf-morph");
  for (int variant = 0; variant < 3; ++variant) {
    GltfBuilder b;
    json& j = b.json();
    const int mesh = b.add_mesh(kTriangle, {}, {0, 0, 1, 0, 0, 1, 0, 0, 1});
    json& prim = j["meshes"][mesh]["primitives"][0];
    // Target 0 lifts vertex 2 by +z and tilts every normal towards +x; target 1 moves vertex 1 by +x.
    prim["targets"] = {{{"POSITION", b.add_floats({0, 0, 0, 0, 0, 0, 0, 0, 2}, 3)},
                        {"NORMAL", b.add_floats({1, 0, 0, 1, 0, 0, 1, 0, 0}, 3)}},
                       {{"POSITION", b.add_floats({0, 0, 0, 4, 0, 0, 0, 0, 0}, 3)}}};
    if (variant >= 1) j["meshes"][mesh]["weights"] = {0.5, 0.25};
    json node = {{"mesh", mesh}, {"translation", {10.0, 0.0, 0.0}}};
    if (variant == 2) node["weights"] = {1.0, 0.0};
    b.add_node(node);
    b.write_gltf(dir / "m.gltf");
    const SceneDesc s = load_gltf(dir / "m.gltf");
    ASSERT_EQ(s.meshes.size(), 1u);
    const Mesh& m = s.meshes[0];
    const double w0 = variant == 0 ? 0.0 : variant == 1 ? 0.5 : 1.0;
    const double w1 = variant == 1 ? 0.25 : 0.0;
    expect_vec(m.positions[1], {10.0 + 1.0 + 4.0 * w1, 0.0, 0.0});
    expect_vec(m.positions[2], {10.0, 1.0, 2.0 * w0});
    expect_vec(m.normals[0], glm::normalize(glm::dvec3(w0, 0.0, 1.0)));
    for (const std::string& w : s.warnings) EXPECT_EQ(w.find("morph"), std::string::npos) << w;
  }
  GltfBuilder bad;
  const int mesh = bad.add_mesh(kTriangle);
  bad.json()["meshes"][mesh]["primitives"][0]["targets"] = {{{"POSITION", bad.add_floats({0, 0, 0, 0, 0, 0, 0, 0, 2}, 3)}}};
  bad.json()["meshes"][mesh]["weights"] = {0.5, 0.5};
  bad.add_node({{"mesh", mesh}});
  bad.write_gltf(dir / "bad.gltf");
  expect_error(dir / "bad.gltf", "1 morph targets but 2 weights");
}

TEST(SceneGltf, KhronosSamples) {
  const std::string root = "/work/shared/assets/khronos_samples/";
  if (!std::filesystem::exists(root)) GTEST_SKIP() << "no " << root;
  {
    const SceneDesc s = load_gltf(root + "Box.gltf");
    EXPECT_EQ(s.triangles, 12u);
    expect_vec(s.bounds_min, {-0.5, -0.5, -0.5}, 1e-5);
    expect_vec(s.bounds_max, {0.5, 0.5, 0.5}, 1e-5);
  }
  {
    const SceneDesc s = load_gltf(root + "SimpleSparseAccessor.gltf");
    expect_vec(s.bounds_max, {6, 4, 0}, 1e-5);
  }
  {
    const SceneDesc s = load_gltf(root + "TriangleWithoutIndices.gltf");
    EXPECT_EQ(s.triangles, 1u);
  }
  {
    const SceneDesc s = load_gltf(root + "Cameras.gltf");
    ASSERT_EQ(s.cameras.size(), 2u);  // a perspective and an orthographic one
    expect_vec(s.cameras[0].position, {0.5, 0.5, 3.0}, 1e-6);
    EXPECT_DOUBLE_EQ(s.cameras[0].yfov, 0.7);
    EXPECT_FALSE(s.cameras[0].orthographic);
    EXPECT_TRUE(s.cameras[1].orthographic);
    EXPECT_DOUBLE_EQ(s.cameras[1].ymag, 1.0);
  }
  {
    // SimpleMorph: base (0,0,0) (1,0,0) (0.5,0.5,0); targets move the apex by (-1,1,0) and
    // (1,1,0); mesh.weights (0.5, 0.5) put it at (0.5, 1.5, 0).
    const SceneDesc s = load_gltf(root + "SimpleMorph.gltf");
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_vec(s.meshes[0].positions[2], {0.5, 1.5, 0.0}, 1e-6);
    expect_vec(s.bounds_max, {1.0, 1.5, 0.0}, 1e-6);
  }
  {
    const SceneDesc s = load_gltf(root + "OrientationTest.gltf");
    expect_vec(s.bounds_min, {-5.3307, -5.3307, -5.3307}, 1e-3);
    expect_vec(s.bounds_max, {5.3307, 5.3307, 5.3307}, 1e-3);
  }
}

}  // namespace
}  // namespace lamina
