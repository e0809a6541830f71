// Reading a glTF 2.0 scene (.gltf or .glb, via tinygltf) into plain data: world-space triangle
// meshes, materials, textures, cameras and punctual lights. Nothing here knows about Embree.
//
// Units of KHR_lights_punctual (glTF spec, KHR_lights_punctual "Light Types"): point and spot
// intensity is in candela (lm/sr), directional in lux (lm/m^2). Lamina is radiometric and treats
// these numbers as W/sr (radiant intensity) and W/m^2 (irradiance on a surface facing the
// light) with no 683 lm/W factor: a point light of intensity I puts irradiance I cos/d^2 on a
// surface. Emissive materials give radiance emissiveFactor x KHR_materials_emissive_strength x
// emissiveTexture (W/(m^2 sr), the same arbitrary unit).
// Blender's exporter writes a point or spot light of P watts as intensity P / (4 pi) x 683 "cd"
// and a sun of S W/m^2 as 683 S "lux" (its default lighting mode, "Standard":
// io_scene_gltf2/blender/exp/lights.py, PBR_WATTS_TO_LUMENS = 683 in blender/com/conversion.py).
// Read as W/sr and W/m^2 that is 683 times Blender's own light, so for files whose
// asset.generator names Blender's exporter the loader divides punctual intensities by 683: a
// P-watt Blender point light becomes P / (4 pi) W/sr, its radiant intensity (docs/rendering.md,
// "Lights and units").
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "materials/base/spectrum.h"

namespace lamina {

// The largest light strength a scene may give: a punctual light's colour x intensity, an
// emissive material's emissiveFactor x emissiveStrength (per channel). The pixels are float
// radiance (at most 3.4e38); a source finite as a double but beyond this would write Inf, and
// the margin of 1e18 leaves room for the inverse square of a light near a surface.
constexpr double kMaxLightStrength = 1e20;
// Blender's lumens per watt (PBR_WATTS_TO_LUMENS), divided out of its exported lights.
constexpr double kBlenderLumensPerWatt = 683.0;
// True for an asset.generator of Blender's glTF exporter ("Khronos glTF Blender I/O vX.Y.Z").
bool is_blender_generator(const std::string& generator);
// The limit as every message gives it: "1e+20 (the image is float radiance, at most 3.4e38)".
std::string light_strength_limit();

// Thrown with one line naming the file and the problem.
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// KHR_texture_transform of one textureInfo: uv' = T(offset) R(rotation) S(scale) uv, with the
// ratified extension's matrices (KHR_texture_transform README, "Overview"):
//   u' = offset.x + cos(r) scale.x u - sin(r) scale.y v,  v' = offset.y + sin(r) scale.x u + cos(r) scale.y v.
// `set` is the TEXCOORD_n the slot reads (textureInfo.texCoord, or the extension's texCoord
// override): 0 or 1 (Mesh::texcoord_set).
struct UvTransform {
  double a = 1.0, b = 0.0, c = 0.0;  // u' = a u + b v + c
  double d = 0.0, e = 1.0, f = 0.0;  // v' = d u + e v + f
  int set = 0;
  glm::dvec2 apply(glm::dvec2 uv) const { return {a * uv.x + b * uv.y + c, d * uv.x + e * uv.y + f}; }
  static UvTransform from(double offset_u, double offset_v, double rotation, double scale_u, double scale_v);
};

// A decoded texture in linear RGB (8-bit colour textures are decoded from sRGB when loaded).
struct Texture {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // row-major from the top row (glTF: v = 0 at the top)
  // The alpha channel (linear, glTF 2.0 section 3.9.2), one per texel; kept only for the base
  // colour textures of MASK and BLEND materials (empty: alpha 1 everywhere).
  std::vector<float> alpha;
  bool clamp_s = false;    // CLAMP_TO_EDGE, else REPEAT (mirrored repeat is read as repeat)
  bool clamp_t = false;
  // Bilinear lookup at texture coordinates uv.
  Spectrum lookup(glm::dvec2 uv) const;
  // Bilinear lookup of the alpha channel (1 where the texture has none kept).
  double alpha_lookup(glm::dvec2 uv) const;
};

// glTF 2.0 material alphaMode (section 3.9.4 "Alpha Coverage").
enum class AlphaMode { kOpaque, kMask, kBlend };

struct Material {
  std::string name;
  Spectrum base_color{0.8};  // linear; glTF default baseColorFactor is 1, see load_gltf
  int base_color_texture = -1;
  // Coverage (renderer/scene/alpha_coverage.h): alpha = base_alpha x the base colour texture's
  // alpha x COLOR_0's alpha. MASK keeps a hit where alpha >= alpha_cutoff; BLEND keeps it with
  // probability alpha (stochastic transparency); OPAQUE ignores alpha.
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  double alpha_cutoff = 0.5;  // glTF default
  double base_alpha = 1.0;    // baseColorFactor[3]
  // KHR_texture_transform of each texture slot (identity without it).
  UvTransform base_color_uv, metallic_roughness_uv, normal_uv, emissive_uv;
  Spectrum emission;  // emissiveFactor x emissive_strength
  int emissive_texture = -1;
  bool double_sided = false;  // recorded; the path tracer shades both sides of every surface
  // glTF 2.0 metallic-roughness (Appendix B; renderer/surfaces/metallic_roughness_surface.h):
  // true for every material of a glTF file; false for the default material (no material: a
  // Lambert surface of base_color) and for materials built in code.
  bool metallic_roughness = false;
  double metallic = 1.0;   // metallicFactor (glTF default 1)
  double roughness = 1.0;  // roughnessFactor (glTF default 1); GGX alpha = roughness^2
  int metallic_roughness_texture = -1;  // linear: G roughness, B metalness (multiplied in)
  int normal_texture = -1;  // linear tangent-space normal map; needs Mesh::tangents
  double normal_scale = 1.0;
  // The glTF extensions that describe light going through the material, as written (read by
  // renderer/layered/gltf_stack.h, which maps them onto a layered stack; docs/gltf_materials.md).
  // Lengths are in scene units.
  struct Transmissive {
    bool transmission = false;          // KHR_materials_transmission present
    double transmission_factor = 0.0;   // transmissionFactor
    bool diffuse_transmission = false;  // KHR_materials_diffuse_transmission present
    double diffuse_transmission_factor = 0.0;
    Spectrum diffuse_transmission_color{1.0};
    bool volume = false;  // KHR_materials_volume present
    double thickness = 0.0;  // thicknessFactor (0: thin-walled)
    // thicknessTexture: its glTF texture index (-1: none); its G channel scales thicknessFactor
    // (renderer/layered/material_binding.cpp binds it as a texture-driven layer thickness).
    int thickness_texture = -1;
    Spectrum attenuation_color{1.0};
    double attenuation_distance = std::numeric_limits<double>::infinity();
    double ior = 1.5;  // KHR_materials_ior (glTF's default 1.5 without it)
    // Transmitting at all: the layered mapping applies (volume and ior alone change nothing:
    // KHR_materials_volume acts only with a transmission extension).
    bool transmits() const {
      return (transmission && transmission_factor > 0.0) || (diffuse_transmission && diffuse_transmission_factor > 0.0);
    }
  } transmissive;
  // Material `extras`, flattened to dotted keys: {"lamina": {"stack": "skin.json"}} gives
  // extras["lamina.stack"] = "skin.json". Non-string leaves are stored as their JSON text.
  std::map<std::string, std::string> extras;
  // The same extras as JSON text ("" if the material has none), for structured values such as
  // the parameter bindings of a layered material ({"lamina": {"bind": [...]}}).
  std::string extras_json;
};

// A triangle mesh in world space (node transforms applied).
struct Mesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;    // one per position, unit length; empty: flat shading
                                     // (glTF: "calculate flat normals" when NORMAL is absent)
  std::vector<glm::vec2> texcoords;  // TEXCOORD_0: empty, or one per position
  std::vector<glm::vec2> texcoords1;  // TEXCOORD_1: empty, or one per position
  // The texture coordinates of set 0 or 1 (UvTransform::set).
  const std::vector<glm::vec2>& texcoord_set(int set) const { return set == 1 ? texcoords1 : texcoords; }
  std::vector<glm::vec3> colours;    // COLOR_0 (linear RGB; multiplies the base colour), or empty
  std::vector<float> colour_alphas;  // COLOR_0's alpha (a VEC4 COLOR_0 on a MASK or BLEND material), or empty
  // Tangents for the material's normal map (xyz unit, w = +-1 the bitangent's handedness:
  // B = w cross(N, T), glTF 2.0 section 3.7.2.1): TANGENT if given, else generated from the
  // texture coordinates; empty if the material has no normal map (or there are no normals or uvs).
  std::vector<glm::vec4> tangents;
  std::vector<std::uint32_t> indices;  // 3 per triangle, degenerate triangles removed
  int material = -1;                   // -1: the default material
};

struct CameraDesc {
  std::string name;       // the camera's name, or its node's when the camera has none
  std::string node_name;
  glm::dvec3 position{0.0};
  glm::dvec3 forward{0.0, 0.0, -1.0};  // glTF cameras look down their local -Z
  glm::dvec3 up{0.0, 1.0, 0.0};
  double yfov = 0.0;  // radians (perspective)
  // The file's aspectRatio (perspective; 0 if absent). The image's aspect is the output's
  // width/height; lamina render warns when this one differs (docs/rendering.md).
  double aspect_ratio = 0.0;
  // glTF "orthographic" (section 3.10.3): parallel rays along forward from the camera's plane
  // through its position, over a view ymag high (half-height, scene units) and ymag x the
  // image's aspect wide (like yfov, the output's width/height decides the width, not xmag).
  bool orthographic = false;
  double ymag = 0.0;
};

enum class LightType { kPoint, kSpot, kDirectional };

struct LightDesc {
  std::string name;
  LightType type = LightType::kPoint;
  Spectrum intensity;  // colour x intensity: W/sr (point, spot) or W/m^2 (directional)
  glm::dvec3 position{0.0};
  glm::dvec3 direction{0.0, 0.0, -1.0};  // the direction light travels (local -Z)
  double cos_inner = 1.0;                // spot cone, cosines of the glTF cone angles
  double cos_outer = 0.0;
};

struct SceneDesc {
  std::string path;
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  // glTF texture index -> index in `textures` (every texture of the file is decoded, also those
  // no material uses, so that parameter bindings can name them by glTF index).
  std::map<int, int> gltf_textures;
  std::vector<CameraDesc> cameras;
  std::vector<LightDesc> lights;
  glm::dvec3 bounds_min{0.0};
  glm::dvec3 bounds_max{0.0};
  std::uint64_t triangles = 0;
  std::uint64_t degenerate_triangles = 0;  // skipped
  std::vector<std::string> warnings;       // each once
  // The files outside the glTF that the loader read (external buffers and images), as it found
  // them: inputs of the render, which no output may overwrite (docs/contracts.md, "Outputs").
  std::vector<std::string> files_read;
  // asset.generator, and the factor applied to every punctual light's intensity (1, or
  // 1 / kBlenderLumensPerWatt for Blender's exporter).
  std::string generator;
  double light_scale = 1.0;

  const Material& material(int index) const;
  void compute_bounds();
};

// Loads every mesh of the default scene (or scene 0). Throws SceneError on malformed files,
// missing buffers or images, non-finite positions, or a scene with no triangles.
SceneDesc load_gltf(const std::string& path);

// A camera that sees the whole bounding box, looking down -Z (used when the file has none).
CameraDesc framing_camera(const SceneDesc& scene, double aspect);

}  // namespace lamina
