#include "renderer/scene/scene_gltf.h"
#include "renderer/scene/gltf_document.h"
#include "renderer/scene/gltf_validate.h"
#include "renderer/scene/texture_filter.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <new>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <tiny_gltf.h>

#include "materials/base/sampling.h"

namespace lamina {
namespace {

// One line: tinygltf's messages can span lines.
std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  while (!s.empty() && (s.back() == ' ' || s.back() == '\r')) s.pop_back();
  return s;
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw SceneError(path + ": " + one_line(what));
}

// sRGB electro-optical transfer function (IEC 61966-2-1), glTF's encoding of colour textures.
float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

// True if a texture the material reads takes TEXCOORD_1.
bool reads_texcoord1(const Material& m) {
  return (m.base_color_texture >= 0 && m.base_color_uv.set == 1) ||
         (m.metallic_roughness_texture >= 0 && m.metallic_roughness_uv.set == 1) ||
         (m.normal_texture >= 0 && m.normal_uv.set == 1) || (m.emissive_texture >= 0 && m.emissive_uv.set == 1);
}

class Loader {
 public:
  Loader(const std::string& path, const tinygltf::Model& model, SceneDesc* out, std::uint64_t max_bytes)
      : path_(path), m_(model), out_(out), max_bytes_(max_bytes) {}

  void run();

 private:
  void visit(int node, const glm::dmat4& parent, int depth);
  void add_primitive(const tinygltf::Mesh& mesh, const tinygltf::Primitive& prim, const glm::dmat4& world,
                     const std::vector<double>& weights);
  void add_morph_targets(const tinygltf::Mesh& mesh, const tinygltf::Primitive& prim, const std::vector<double>& weights,
                         std::size_t nv, std::vector<double>* p, std::vector<double>* n, std::vector<double>* tangent);
  std::vector<double> read_accessor(int index, int want_components, const char* what);
  // linear: data (normal and metallic-roughness maps), not sRGB colour.
  void make_tangents(const std::vector<double>& given, const glm::dmat3& m3, bool mirrored, int set, Mesh* mesh);
  int texture(int gltf_texture, bool linear = false);
  void read_transmissive(const tinygltf::Material& gm, Material::Transmissive* out);
  void read_thickness_texture(const tinygltf::Value& volume, const std::string& material, Material::Transmissive* out);
  void warn(const std::string& w) {
    if (warned_.insert(w).second) out_->warnings.push_back(w);
  }

  const std::string& path_;
  const tinygltf::Model& m_;
  SceneDesc* out_;
  std::uint64_t max_bytes_;  // max_scene_bytes()
  std::set<std::string> warned_;
  std::map<int, int> textures_;  // glTF texture index -> SceneDesc::textures index
  std::map<int, int> linear_textures_;  // the same, decoded without the sRGB curve
  // glTF textures that are the base colour of a MASK or BLEND material: their alpha is kept.
  std::set<int> alpha_textures_;
};

glm::dmat4 local_transform(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) return glm::make_mat4(n.matrix.data());  // column-major, as glm
  glm::dmat4 t(1.0), r(1.0), s(1.0);
  if (n.translation.size() == 3)
    t = glm::translate(glm::dmat4(1.0), glm::dvec3(n.translation[0], n.translation[1], n.translation[2]));
  if (n.rotation.size() == 4) {
    // glTF stores (x, y, z, w); glm's constructor takes (w, x, y, z). Normalise: exporters
    // write quaternions off unit length by ~1e-6 (Khronos Cameras.gltf).
    glm::dquat q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
    // Components so large (or small) that the squared length overflows (or underflows) are
    // scaled first; unit-ish quaternions, every real file's, take the plain path unchanged.
    const double len2 = glm::dot(q, q);
    if (!(len2 > 0.0 && std::isfinite(len2))) {
      const double m = std::max({std::abs(q.w), std::abs(q.x), std::abs(q.y), std::abs(q.z)});
      if (m > 0.0 && std::isfinite(m)) q = q * (1.0 / m);
    }
    r = glm::mat4_cast(glm::normalize(q));
  }
  if (n.scale.size() == 3) s = glm::scale(glm::dmat4(1.0), glm::dvec3(n.scale[0], n.scale[1], n.scale[2]));
  return t * r * s;  // glTF: M = T * R * S
}

bool is_finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// Embree takes single-precision coordinates: a point must stay finite, with room to spare, as a
// float (the same bound as vertex positions, add_primitive).
bool fits_float(const glm::dvec3& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::abs(p.x) <= 1e30 &&
         std::abs(p.y) <= 1e30 && std::abs(p.z) <= 1e30;
}

// v / |v|, or nullopt when v has no direction (zero, or not finite). The plain normalisation for
// every ordinary v (so valid scenes give the same bits as ever), rescaled first where |v|^2
// would overflow or underflow.
std::optional<glm::dvec3> unit(glm::dvec3 v) {
  const double len2 = glm::dot(v, v);
  if (!(len2 > 0.0 && std::isfinite(len2))) {
    const double m = std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
    if (!(m > 0.0 && std::isfinite(m))) return std::nullopt;
    v /= m;
  }
  const glm::dvec3 u = glm::normalize(v);
  if (!std::isfinite(u.x) || !std::isfinite(u.y) || !std::isfinite(u.z)) return std::nullopt;
  return u;
}

std::string node_at(int i) { return "nodes[" + std::to_string(i) + "]"; }

std::vector<double> Loader::read_accessor(int index, int want, const char* what) {
  if (index < 0 || index >= static_cast<int>(m_.accessors.size()))
    fail(path_, std::string("accessor for ") + what + " is out of range");
  const tinygltf::Accessor& a = m_.accessors[index];
  const int comps = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
  const int size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
  if (comps <= 0 || size <= 0 || (want > 0 && comps != want))
    fail(path_, std::string("accessor ") + std::to_string(index) + " (" + what + ") has an unexpected type");
  std::vector<double> v(a.count * comps, 0.0);

  auto decode = [&](const unsigned char* p, int type, bool normalized) -> double {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, p, 4); return f; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
      case TINYGLTF_COMPONENT_TYPE_BYTE: { auto b = static_cast<std::int8_t>(p[0]); return normalized ? std::max(b / 127.0, -1.0) : b; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { std::uint16_t u; std::memcpy(&u, p, 2); return normalized ? u / 65535.0 : u; }
      case TINYGLTF_COMPONENT_TYPE_SHORT: { std::int16_t s; std::memcpy(&s, p, 2); return normalized ? std::max(s / 32767.0, -1.0) : s; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t u; std::memcpy(&u, p, 4); return u; }
      default: fail(path_, std::string("accessor (") + what + ") has an unsupported component type");
    }
  };
  // Reads `count` elements of `comps` components from a buffer view, bounds-checked.
  auto read_view = [&](int view_index, std::size_t offset, std::size_t count, int n, int type, int stride_default,
                       bool normalized, double* dst) {
    if (view_index < 0 || view_index >= static_cast<int>(m_.bufferViews.size()))
      fail(path_, std::string("buffer view for ") + what + " is out of range");
    const tinygltf::BufferView& bv = m_.bufferViews[view_index];
    if (bv.buffer < 0 || bv.buffer >= static_cast<int>(m_.buffers.size()))
      fail(path_, std::string("buffer for ") + what + " is missing");
    const std::vector<unsigned char>& data = m_.buffers[bv.buffer].data;
    const std::size_t csize = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(type));
    const std::size_t stride = bv.byteStride ? bv.byteStride : static_cast<std::size_t>(stride_default);
    const std::size_t begin = bv.byteOffset + offset;
    if (count > 0) {
      const std::size_t end = begin + (count - 1) * stride + n * csize;
      if (end > bv.byteOffset + bv.byteLength || end > data.size())
        fail(path_, std::string("accessor data for ") + what + " runs past the end of its buffer (truncated file?)");
    }
    for (std::size_t i = 0; i < count; ++i)
      for (int c = 0; c < n; ++c) dst[i * n + c] = decode(&data[begin + i * stride + c * csize], type, normalized);
  };
  if (a.bufferView >= 0)
    read_view(a.bufferView, a.byteOffset, a.count, comps, a.componentType, comps * size, a.normalized, v.data());
  if (a.sparse.isSparse) {  // glTF 2.0 section 3.6.2.3: substitute `count` elements
    const std::size_t n = static_cast<std::size_t>(a.sparse.count);
    std::vector<double> idx(n), val(n * comps);
    const int itype = a.sparse.indices.componentType;
    read_view(a.sparse.indices.bufferView, a.sparse.indices.byteOffset, n, 1, itype,
              tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(itype)), false, idx.data());
    read_view(a.sparse.values.bufferView, a.sparse.values.byteOffset, n, comps, a.componentType, comps * size,
              a.normalized, val.data());
    for (std::size_t i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(idx[i]);
      if (k >= a.count) fail(path_, std::string("sparse index out of range in ") + what);
      for (int c = 0; c < comps; ++c) v[k * comps + c] = val[i * comps + c];
    }
  }
  return v;
}

int Loader::texture(int t, bool linear) {
  if (t < 0) return -1;
  std::map<int, int>& cache = linear ? linear_textures_ : textures_;
  auto it = cache.find(t);
  if (it != cache.end()) return it->second;
  if (t >= static_cast<int>(m_.textures.size())) fail(path_, "texture index " + std::to_string(t) + " is out of range");
  const tinygltf::Texture& gt = m_.textures[t];
  if (gt.source < 0 || gt.source >= static_cast<int>(m_.images.size()))
    fail(path_, "texture " + std::to_string(t) + " has no image");
  const tinygltf::Image& im = m_.images[gt.source];
  if (im.width <= 0 || im.height <= 0 || im.image.empty())
    fail(path_, "image '" + (im.uri.empty() ? im.name : im.uri) + "' could not be decoded");
  Texture tex;
  tex.width = im.width;
  tex.height = im.height;
  tex.rgb.resize(static_cast<std::size_t>(im.width) * im.height * 3);
  const int bytes = im.bits == 16 ? 2 : 1;
  const std::size_t needed = static_cast<std::size_t>(im.width) * im.height * im.component * bytes;
  if (im.image.size() < needed || im.component < 1) fail(path_, "image '" + im.uri + "' has inconsistent size");
  // Alpha is the last channel of grey+alpha and RGBA images, stored linearly (glTF 2.0 section
  // 3.9.2: "the alpha channel is linear"); kept only where a MASK or BLEND material reads it.
  const bool keep_alpha = !linear && alpha_textures_.count(t) && (im.component == 2 || im.component == 4);
  if (keep_alpha) tex.alpha.resize(static_cast<std::size_t>(im.width) * im.height);
  auto channel = [&](std::size_t p, int src) {
    const std::size_t o = (p * im.component + src) * bytes;
    return bytes == 2 ? (im.image[o] | (im.image[o + 1] << 8)) / 65535.0f : im.image[o] / 255.0f;
  };
  // 8-bit colour: the 256 decoded values once, not a pow per texel and channel (the head's 1024^2
  // colour map: 3 million calls, half of the scene's loading time).
  static const std::array<float, 256> kSrgb8 = [] {
    std::array<float, 256> table{};
    for (int i = 0; i < 256; ++i) table[i] = srgb_to_linear(i / 255.0f);
    return table;
  }();
  auto colour = [&](std::size_t p, int src) {
    if (linear) return channel(p, src);
    if (bytes == 1) return kSrgb8[im.image[p * im.component + src]];
    return srgb_to_linear(channel(p, src));
  };
  for (std::size_t p = 0; p < static_cast<std::size_t>(im.width) * im.height; ++p) {
    for (int c = 0; c < 3; ++c)
      tex.rgb[p * 3 + c] = colour(p, im.component >= 3 ? c : 0);  // grey (and grey+alpha) expands to RGB
    if (keep_alpha) tex.alpha[p] = channel(p, im.component - 1);
  }
  if (gt.sampler >= 0 && gt.sampler < static_cast<int>(m_.samplers.size())) {
    tex.clamp_s = m_.samplers[gt.sampler].wrapS == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    tex.clamp_t = m_.samplers[gt.sampler].wrapT == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  }
  out_->textures.push_back(std::move(tex));
  return cache[t] = static_cast<int>(out_->textures.size()) - 1;
}

void flatten_extras(const tinygltf::Value& v, const std::string& prefix, std::map<std::string, std::string>* out) {
  if (v.IsObject()) {
    for (const std::string& k : v.Keys()) flatten_extras(v.Get(k), prefix.empty() ? k : prefix + "." + k, out);
  } else if (v.IsString()) {
    (*out)[prefix] = v.Get<std::string>();
  } else if (v.IsNumber()) {
    std::ostringstream s;
    s.precision(17);
    s << v.GetNumberAsDouble();
    (*out)[prefix] = s.str();
  } else if (v.IsBool()) {
    (*out)[prefix] = v.Get<bool>() ? "true" : "false";
  } else if (!prefix.empty()) {
    (*out)[prefix] = "";  // arrays and nulls: present but not representable as one string
  }
}

// tinygltf's Value as JSON text (numbers with 17 digits, so doubles round-trip).
void write_json(const tinygltf::Value& v, std::ostringstream* out) {
  if (v.IsObject()) {
    *out << '{';
    bool first = true;
    for (const std::string& k : v.Keys()) {
      if (!first) *out << ',';
      first = false;
      write_json(tinygltf::Value(k), out);
      *out << ':';
      write_json(v.Get(k), out);
    }
    *out << '}';
  } else if (v.IsArray()) {
    *out << '[';
    for (std::size_t i = 0; i < v.ArrayLen(); ++i) {
      if (i) *out << ',';
      write_json(v.Get(static_cast<int>(i)), out);
    }
    *out << ']';
  } else if (v.IsString()) {
    *out << '"';
    for (char c : v.Get<std::string>()) {
      if (c == '"' || c == '\\') *out << '\\' << c;
      else if (static_cast<unsigned char>(c) < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", c);
        *out << buf;
      } else *out << c;
    }
    *out << '"';
  } else if (v.IsNumber()) {
    *out << v.GetNumberAsDouble();
  } else if (v.IsBool()) {
    *out << (v.Get<bool>() ? "true" : "false");
  } else {
    *out << "null";
  }
}

// Morph targets at the given weights (glTF 2.0 section 3.7.2.2): each target holds displacements
// of POSITION, NORMAL and TANGENT (xyz; a target's TANGENT is a VEC3), and the rendered attribute
// is base + sum_i w_i target_i, in the mesh's local space (before the node transform). Normals
// and tangents are renormalised later, as every normal is. Targets of weight 0 are not read.
void Loader::add_morph_targets(const tinygltf::Mesh& gmesh, const tinygltf::Primitive& prim,
                               const std::vector<double>& weights, std::size_t nv, std::vector<double>* p,
                               std::vector<double>* n, std::vector<double>* tangent) {
  if (weights.size() != prim.targets.size())
    fail(path_, "mesh '" + gmesh.name + "': " + std::to_string(prim.targets.size()) + " morph targets but " +
                    std::to_string(weights.size()) + " weights (glTF 2.0 section 3.7.2.2: one weight per target)");
  for (std::size_t k = 0; k < prim.targets.size(); ++k) {
    const double w = weights[k];
    if (!std::isfinite(w)) fail(path_, "mesh '" + gmesh.name + "': morph weight " + std::to_string(k) + " is not finite");
    if (w == 0.0) continue;
    auto displace = [&](const char* name, std::vector<double>* base, int stride) {
      auto it = prim.targets[k].find(name);
      if (it == prim.targets[k].end() || base->empty()) return;
      const std::vector<double> d = read_accessor(it->second, 3, name);
      if (d.size() != 3 * nv)
        fail(path_, "mesh '" + gmesh.name + "': morph target " + std::to_string(k) + " " + name +
                        " has a different vertex count from the base mesh");
      for (std::size_t i = 0; i < nv; ++i)
        for (int c = 0; c < 3; ++c) (*base)[stride * i + c] += w * d[3 * i + c];
    };
    displace("POSITION", p, 3);
    displace("NORMAL", n, 3);
    displace("TANGENT", tangent, 4);
  }
}

void Loader::add_primitive(const tinygltf::Mesh& gmesh, const tinygltf::Primitive& prim, const glm::dmat4& world,
                           const std::vector<double>& weights) {
  const int mode = prim.mode == -1 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    warn("primitives of points or lines are skipped");
    return;
  }
  auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) {
    warn("a primitive without POSITION is skipped");
    return;
  }
  if (prim.attributes.count("JOINTS_0")) warn("skins are ignored (the rest pose is rendered)");

  std::vector<double> p = read_accessor(pos_it->second, 3, "POSITION");
  const std::size_t nv = p.size() / 3;
  std::vector<double> n, uv, uv1, tangent;
  if (auto it = prim.attributes.find("NORMAL"); it != prim.attributes.end()) n = read_accessor(it->second, 3, "NORMAL");
  if (auto it = prim.attributes.find("TEXCOORD_0"); it != prim.attributes.end()) uv = read_accessor(it->second, 2, "TEXCOORD_0");
  if (auto it = prim.attributes.find("TEXCOORD_1"); it != prim.attributes.end()) uv1 = read_accessor(it->second, 2, "TEXCOORD_1");
  // COLOR_0 (glTF 2.0 section 3.7.2.1): RGB or RGBA, float or normalized unsigned bytes/shorts,
  // linear; it multiplies the base colour. Its alpha (VEC4) is kept for MASK and BLEND materials.
  std::vector<double> colour;
  int colour_comps = 0;
  if (auto it = prim.attributes.find("COLOR_0"); it != prim.attributes.end()) {
    colour = read_accessor(it->second, 0, "COLOR_0");
    colour_comps = nv > 0 ? static_cast<int>(colour.size() / nv) : 0;
    if (colour.size() != static_cast<std::size_t>(colour_comps) * nv || (colour_comps != 3 && colour_comps != 4))
      fail(path_, "mesh '" + gmesh.name + "': COLOR_0 must be a VEC3 or VEC4 per vertex");
  }
  const bool normal_mapped = prim.material >= 0 && prim.material < static_cast<int>(out_->materials.size()) &&
                             out_->materials[prim.material].normal_texture >= 0;
  if (auto it = prim.attributes.find("TANGENT"); normal_mapped && it != prim.attributes.end())
    tangent = read_accessor(it->second, 4, "TANGENT");
  if ((!n.empty() && n.size() != p.size()) || (!uv.empty() && uv.size() / 2 != nv) || (!uv1.empty() && uv1.size() / 2 != nv) ||
      (!tangent.empty() && tangent.size() / 4 != nv))
    fail(path_, "mesh '" + gmesh.name + "' has attributes of different lengths");
  if (!prim.targets.empty()) add_morph_targets(gmesh, prim, weights, nv, &p, &n, &tangent);

  std::vector<std::uint32_t> idx;
  if (prim.indices >= 0) {
    // Indices are unsigned integers (glTF 2.0 spec 3.7.2.1: UNSIGNED_BYTE, UNSIGNED_SHORT or
    // UNSIGNED_INT); a signed or float accessor could hold -128 or 1.5 (found by fuzz_gltf: a
    // negative index converted to unsigned is undefined behaviour).
    const int type = m_.accessors[prim.indices].componentType;
    if (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      fail(path_, "accessors[" + std::to_string(prim.indices) + "]: indices must be unsigned bytes, shorts or ints (componentType " +
                      std::to_string(type) + ")");
    for (double d : read_accessor(prim.indices, 1, "indices")) {
      if (!(d >= 0.0 && d < static_cast<double>(nv))) fail(path_, "mesh '" + gmesh.name + "' has a vertex index out of range");
      idx.push_back(static_cast<std::uint32_t>(d));
    }
  } else {
    for (std::size_t i = 0; i < nv; ++i) idx.push_back(static_cast<std::uint32_t>(i));
  }
  // Strips and fans become triangle lists, keeping the winding glTF 2.0 gives them (section
  // 3.7.2.1): strip triangle i is (v_i, v_{i+1+i%2}, v_{i+2-i%2}), fan triangle i is
  // (v_{i+1}, v_{i+2}, v_0).
  if (mode == TINYGLTF_MODE_TRIANGLE_STRIP || mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    std::vector<std::uint32_t> list;
    for (std::size_t i = 0; i + 2 < idx.size(); ++i) {
      if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)
        list.insert(list.end(), {idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]});
      else
        list.insert(list.end(), {idx[i + 1], idx[i + 2], idx[0]});
    }
    if (idx.size() < 3) warn("a strip or fan of fewer than 3 vertices has no triangles");
    idx = std::move(list);
  }
  if (idx.size() % 3 != 0) fail(path_, "mesh '" + gmesh.name + "' has an index count that is not a multiple of 3");

  // Normals transform with the inverse transpose of the upper 3x3 (pbrt-v4 section 3.10.3).
  const glm::dmat3 m3(world);
  const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(m3));
  // A mirroring transform (negative determinant) reverses the winding; glTF says to flip it
  // back so faces keep their front side (glTF 2.0 section 3.7.4).
  const bool mirrored = glm::determinant(m3) < 0.0;

  Mesh mesh;
  mesh.name = gmesh.name;
  mesh.material = prim.material;
  if (prim.material >= static_cast<int>(m_.materials.size())) fail(path_, "mesh '" + gmesh.name + "' uses a missing material");
  mesh.positions.resize(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    const glm::dvec3 w = glm::dvec3(world * glm::dvec4(p[3 * i], p[3 * i + 1], p[3 * i + 2], 1.0));
    if (!std::isfinite(w.x) || !std::isfinite(w.y) || !std::isfinite(w.z) || std::abs(w.x) > 1e30 ||
        std::abs(w.y) > 1e30 || std::abs(w.z) > 1e30)
      fail(path_, "mesh '" + gmesh.name + "' has a non-finite vertex position (vertex " + std::to_string(i) + ")");
    mesh.positions[i] = glm::vec3(w);
  }
  if (!n.empty()) {
    mesh.normals.resize(nv);
    for (std::size_t i = 0; i < nv; ++i) {
      glm::dvec3 w = normal_matrix * glm::dvec3(n[3 * i], n[3 * i + 1], n[3 * i + 2]);
      const double len = glm::length(w);
      if (!(len > 0.0) || !std::isfinite(len)) {  // unusable normal: fall back to flat shading
        warn("invalid vertex normals replaced by flat shading");
        mesh.normals.clear();
        break;
      }
      mesh.normals[i] = glm::vec3(w / len);
    }
  }
  if (!colour.empty()) {
    mesh.colours.resize(nv);
    for (std::size_t i = 0; i < nv; ++i) {
      const glm::dvec3 c(colour[colour_comps * i], colour[colour_comps * i + 1], colour[colour_comps * i + 2]);
      if (!std::isfinite(c.x + c.y + c.z) || std::min({c.x, c.y, c.z}) < 0.0)
        fail(path_, "mesh '" + gmesh.name + "': COLOR_0 of vertex " + std::to_string(i) + " is negative or not finite");
      mesh.colours[i] = glm::vec3(c);
    }
    if (colour_comps == 4 && out_->material(prim.material).alpha_mode != AlphaMode::kOpaque) {
      mesh.colour_alphas.resize(nv);
      for (std::size_t i = 0; i < nv; ++i) {
        const double a = colour[4 * i + 3];
        if (!(a >= 0.0 && a <= 1.0))
          fail(path_, "mesh '" + gmesh.name + "': COLOR_0 alpha of vertex " + std::to_string(i) + " is not in [0, 1]");
        mesh.colour_alphas[i] = static_cast<float>(a);
      }
    }
  }
  if (!uv.empty()) {
    mesh.texcoords.resize(nv);
    for (std::size_t i = 0; i < nv; ++i) mesh.texcoords[i] = glm::vec2(uv[2 * i], uv[2 * i + 1]);
  }
  if (!uv1.empty()) {
    mesh.texcoords1.resize(nv);
    for (std::size_t i = 0; i < nv; ++i) mesh.texcoords1[i] = glm::vec2(uv1[2 * i], uv1[2 * i + 1]);
  }
  if (prim.material >= 0 && prim.material < static_cast<int>(out_->materials.size()) && uv1.empty() &&
      reads_texcoord1(out_->materials[prim.material]))
    warn("mesh '" + gmesh.name + "': material '" + out_->materials[prim.material].name +
         "' reads TEXCOORD_1, which the mesh does not have: its textures are read at (0, 0) there");
  for (std::size_t t = 0; t < idx.size(); t += 3) {
    std::uint32_t a = idx[t], b = idx[t + 1], c = idx[t + 2];
    if (mirrored) std::swap(b, c);
    const glm::dvec3 e1 = glm::dvec3(mesh.positions[b]) - glm::dvec3(mesh.positions[a]);
    const glm::dvec3 e2 = glm::dvec3(mesh.positions[c]) - glm::dvec3(mesh.positions[a]);
    // Degenerate: the edges are parallel to within 1e-12 (sin of the angle between them), or
    // an edge has zero length. Such triangles have no area to hit or to emit from.
    const double cross = glm::length(glm::cross(e1, e2));
    if (!(cross > 1e-12 * glm::length(e1) * glm::length(e2))) {
      ++out_->degenerate_triangles;
      continue;
    }
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
  }
  if (normal_mapped) {
    if (mesh.normals.empty() || mesh.texcoord_set(out_->materials[prim.material].normal_uv.set).empty())
      warn("normal maps need vertex normals and texture coordinates: ignored where they are missing");
    else
      make_tangents(tangent, m3, mirrored, out_->materials[prim.material].normal_uv.set, &mesh);
  }
  out_->triangles += mesh.indices.size() / 3;
  if (!mesh.indices.empty()) out_->meshes.push_back(std::move(mesh));
}

// Tangent frames for normal maps. Given TANGENT: xyz transformed by the node's matrix
// (tangents are surface directions, unlike normals), w flipped by a mirroring transform. Else
// generated: per triangle T = dP/du and B = -dP/dv (glTF's v runs down the image, and a normal
// map's +Y is up the image: glTF 2.0 section 3.9.3), accumulated per vertex, then T made
// orthogonal to the vertex normal (Gram-Schmidt) and w = sign(cross(N, T) . B). This is
// MikkTSpace's result for the usual smooth meshes, not its exact splitting of vertices at UV
// seams and sharp edges (noted in docs/contracts.md).
void Loader::make_tangents(const std::vector<double>& given, const glm::dmat3& m3, bool mirrored, int set, Mesh* mesh) {
  const std::vector<glm::vec2>& uvs = mesh->texcoord_set(set);
  const std::size_t nv = mesh->positions.size();
  mesh->tangents.assign(nv, glm::vec4(0.0f));
  std::vector<glm::dvec3> t_acc(nv, glm::dvec3(0.0)), b_acc(nv, glm::dvec3(0.0));
  if (!given.empty()) {
    for (std::size_t i = 0; i < nv; ++i) {
      t_acc[i] = m3 * glm::dvec3(given[4 * i], given[4 * i + 1], given[4 * i + 2]);
      const double w = given[4 * i + 3] < 0.0 ? -1.0 : 1.0;
      b_acc[i] = glm::cross(glm::dvec3(mesh->normals[i]), t_acc[i]) * (mirrored ? -w : w);
    }
  } else {
    for (std::size_t k = 0; k < mesh->indices.size(); k += 3) {
      const std::uint32_t a = mesh->indices[k], b = mesh->indices[k + 1], c = mesh->indices[k + 2];
      const glm::dvec3 e1 = glm::dvec3(mesh->positions[b]) - glm::dvec3(mesh->positions[a]);
      const glm::dvec3 e2 = glm::dvec3(mesh->positions[c]) - glm::dvec3(mesh->positions[a]);
      const glm::dvec2 d1 = glm::dvec2(uvs[b]) - glm::dvec2(uvs[a]);
      const glm::dvec2 d2 = glm::dvec2(uvs[c]) - glm::dvec2(uvs[a]);
      const double det = d1.x * d2.y - d2.x * d1.y;
      if (!(std::abs(det) > 1e-20) || !std::isfinite(det)) continue;  // no uv area: no frame from it
      const glm::dvec3 dp_du = (e1 * d2.y - e2 * d1.y) / det;
      const glm::dvec3 dp_dv = (e2 * d1.x - e1 * d2.x) / det;
      for (std::uint32_t v : {a, b, c}) {
        t_acc[v] += dp_du;
        b_acc[v] -= dp_dv;
      }
    }
  }
  for (std::size_t i = 0; i < nv; ++i) {
    const glm::dvec3 nrm(mesh->normals[i]);
    glm::dvec3 t = t_acc[i] - nrm * glm::dot(nrm, t_acc[i]);
    const double len = glm::length(t);
    if (!(len > 1e-20) || !std::isfinite(len)) continue;  // (0, 0, 0, 0): the map is not applied here
    t /= len;
    const double w = glm::dot(glm::cross(nrm, t), b_acc[i]) < 0.0 ? -1.0 : 1.0;
    mesh->tangents[i] = glm::vec4(glm::vec3(t), static_cast<float>(w));
  }
}

// KHR_materials_volume's thicknessTexture: a textureInfo whose G channel scales thicknessFactor.
// It is read as a texture-driven parameter, which reads TEXCOORD_0 (docs/gltf_materials.md).
void Loader::read_thickness_texture(const tinygltf::Value& volume, const std::string& material,
                                    Material::Transmissive* out) {
  if (!volume.Has("thicknessTexture")) return;
  const tinygltf::Value& info = volume.Get("thicknessTexture");
  const std::string where = "material '" + material + "': extensions.KHR_materials_volume.thicknessTexture";
  if (!info.IsObject() || !info.Has("index") || !info.Get("index").IsNumber())
    fail(path_, where + ": expected a textureInfo with an index");
  const int index = info.Get("index").GetNumberAsInt();
  if (index < 0 || index >= static_cast<int>(m_.textures.size()))
    fail(path_, where + ".index: " + std::to_string(index) + " is not a texture of the file");
  if (info.Has("texCoord") && info.Get("texCoord").IsNumber() && info.Get("texCoord").GetNumberAsInt() != 0)
    warn(where + " reads TEXCOORD_" + std::to_string(info.Get("texCoord").GetNumberAsInt()) +
         ": texture-driven parameters read TEXCOORD_0, which is used");
  out->thickness_texture = index;
}

// KHR_materials_transmission, _diffuse_transmission, _volume and _ior, as written (defaults from
// each extension's README). Values outside the ranges the extensions give are errors naming the
// material and the key; their textures are not read (warned).
void Loader::read_transmissive(const tinygltf::Material& gm, Material::Transmissive* out) {
  auto bad = [&](const std::string& ext, const std::string& key, const std::string& why) {
    fail(path_, "material '" + gm.name + "': extensions." + ext + "." + key + ": " + why);
  };
  auto number = [&](const tinygltf::Value& e, const std::string& ext, const char* key, double fallback, double lo, double hi) {
    if (!e.Has(key)) return fallback;
    const tinygltf::Value& v = e.Get(key);
    const double x = v.IsNumber() ? v.GetNumberAsDouble() : std::numeric_limits<double>::quiet_NaN();
    if (!(x >= lo && x <= hi)) {
      std::ostringstream s;
      s << "must be a number in [" << lo << ", " << hi << "]";
      bad(ext, key, s.str());
    }
    return x;
  };
  auto colour = [&](const tinygltf::Value& e, const std::string& ext, const char* key) {
    if (!e.Has(key)) return Spectrum(1.0);
    const tinygltf::Value& v = e.Get(key);
    if (!v.IsArray() || v.ArrayLen() != 3) bad(ext, key, "must be an array of 3 numbers in [0, 1]");
    Spectrum c;
    for (int k = 0; k < 3; ++k) {
      const tinygltf::Value& x = v.Get(k);
      c[k] = x.IsNumber() ? x.GetNumberAsDouble() : -1.0;
      if (!(c[k] >= 0.0 && c[k] <= 1.0)) bad(ext, key, "must be an array of 3 numbers in [0, 1]");
    }
    return c;
  };
  auto textures_ignored = [&](const tinygltf::Value& e, std::initializer_list<const char*> keys) {
    for (const char* k : keys)
      if (e.Has(k)) warn(std::string("glTF transmission/volume textures (") + k + ") are not read: their factors are used");
  };
  const double inf = std::numeric_limits<double>::infinity();
  if (auto it = gm.extensions.find("KHR_materials_transmission"); it != gm.extensions.end()) {
    out->transmission = true;
    out->transmission_factor = number(it->second, it->first, "transmissionFactor", 0.0, 0.0, 1.0);
    textures_ignored(it->second, {"transmissionTexture"});
  }
  if (auto it = gm.extensions.find("KHR_materials_diffuse_transmission"); it != gm.extensions.end()) {
    out->diffuse_transmission = true;
    out->diffuse_transmission_factor = number(it->second, it->first, "diffuseTransmissionFactor", 0.0, 0.0, 1.0);
    out->diffuse_transmission_color = colour(it->second, it->first, "diffuseTransmissionColorFactor");
    textures_ignored(it->second, {"diffuseTransmissionTexture", "diffuseTransmissionColorTexture"});
  }
  if (auto it = gm.extensions.find("KHR_materials_volume"); it != gm.extensions.end()) {
    out->volume = true;
    out->thickness = number(it->second, it->first, "thicknessFactor", 0.0, 0.0, 1e30);
    out->attenuation_color = colour(it->second, it->first, "attenuationColor");
    out->attenuation_distance = number(it->second, it->first, "attenuationDistance", inf, 0.0, inf);
    if (!(out->attenuation_distance > 0.0)) bad(it->first, "attenuationDistance", "must be > 0");
    read_thickness_texture(it->second, gm.name, out);
  }
  if (auto it = gm.extensions.find("KHR_materials_ior"); it != gm.extensions.end()) {
    // Any finite value >= 0 loads (the extension's schema has minimum 0); a transmitting
    // material needs an index >= 1 for its stack (gltf_stack.cpp says so), the others ignore it.
    out->ior = number(it->second, it->first, "ior", 1.5, 0.0, 1e30);
  }
}

void Loader::visit(int index, const glm::dmat4& parent, int depth) {
  // validate_gltf has checked that the nodes form a strict forest (glTF 2.0 section 3.5.3), so
  // each node is visited once. The recursion stays bounded all the same: real hierarchies are a
  // few dozen levels deep, and a line of 100,000 nodes would exhaust the stack.
  if (index < 0 || index >= static_cast<int>(m_.nodes.size())) fail(path_, node_at(index) + ": is out of range");
  if (depth > 256) fail(path_, node_at(index) + ": the node hierarchy is deeper than 256 levels");
  const tinygltf::Node& node = m_.nodes[index];
  const glm::dmat4 local = local_transform(node);
  if (!is_finite(local)) fail(path_, node_at(index) + ": transform is not finite");
  const glm::dmat4 world = parent * local;
  // A chain of large scales overflows to infinity (and infinity times 0 to NaN): nothing
  // non-finite may reach the meshes, cameras and lights below, and so Embree.
  if (!is_finite(world))
    fail(path_, node_at(index) + ": transform is not finite (the product of its own and its parents' transforms overflows)");
  const glm::dmat3 m3(world);

  if (node.mesh >= 0) {
    if (node.mesh >= static_cast<int>(m_.meshes.size()))
      fail(path_, node_at(index) + ": mesh " + std::to_string(node.mesh) + " is out of range");
    const tinygltf::Mesh& mesh = m_.meshes[node.mesh];
    // Default morph weights (glTF 2.0 section 3.7.2.2): the node's `weights` override the mesh's;
    // without either, every weight is 0. Animations are not played.
    const std::vector<double>& weights = !node.weights.empty() ? node.weights : mesh.weights;
    for (const tinygltf::Primitive& prim : mesh.primitives) {
      if (weights.empty() && !prim.targets.empty()) {
        add_primitive(mesh, prim, world, std::vector<double>(prim.targets.size(), 0.0));
      } else {
        add_primitive(mesh, prim, world, weights);
      }
    }
  }
  if (node.camera >= static_cast<int>(m_.cameras.size()))
    fail(path_, node_at(index) + ": camera " + std::to_string(node.camera) + " is out of range");
  if (node.camera >= 0) {
    const tinygltf::Camera& c = m_.cameras[node.camera];
    if (c.type != "perspective" && c.type != "orthographic") {
      warn("cameras of type '" + c.type + "' are skipped");
    } else {
      CameraDesc cam;
      cam.name = camera_display_name(c.name, node.name);  // batch manifests check --camera by it too
      cam.node_name = node.name;
      cam.position = glm::dvec3(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
      // The camera's frame is its node's: it looks down local -Z with local +Y up (glTF 2.0
      // section 3.10.1 "Cameras"). A scale of 0 leaves no direction to look in, and parallel
      // directions (a singular matrix) no image plane: every camera ray would be NaN.
      const auto forward = unit(m3 * glm::dvec3(0.0, 0.0, -1.0));
      const auto up = unit(m3 * glm::dvec3(0.0, 1.0, 0.0));
      if (!forward || !up)
        fail(path_, node_at(index) + ": camera transform is degenerate (scale 0: its forward or up direction has length 0)");
      // sin of the angle between them; exporters' frames are orthogonal to ~1e-7.
      if (!(glm::length(glm::cross(*forward, *up)) > 1e-6))
        fail(path_, node_at(index) + ": camera transform is degenerate (its forward and up directions are parallel)");
      if (!fits_float(cam.position))
        fail(path_, node_at(index) + ": camera position is beyond the range of single precision (Embree traces in float)");
      cam.forward = *forward;
      cam.up = *up;
      if (c.type == "orthographic") {
        // The view's half-height in the camera's frame, so the node's scale along +Y scales it.
        cam.orthographic = true;
        const double ymag = std::abs(c.orthographic.ymag);
        cam.ymag = ymag * glm::length(m3 * glm::dvec3(0.0, 1.0, 0.0));
        if (c.orthographic.ymag < 0.0) warn("a negative orthographic ymag is read as its magnitude");
        // validate_gltf refused 0 and non-finite values (section 5.16).
        if (!(cam.ymag > 0.0 && std::isfinite(cam.ymag)))
          fail(path_, "cameras[" + std::to_string(node.camera) + "].orthographic.ymag: is not a positive finite size");
      } else {
        cam.yfov = c.perspective.yfov;
        cam.aspect_ratio = c.perspective.aspectRatio;
        // validate_gltf refused anything else (cameras[i].perspective.yfov, section 5.14).
        if (!(cam.yfov > 0.0 && cam.yfov < kPi))
          fail(path_, "cameras[" + std::to_string(node.camera) + "].perspective.yfov: is not in (0, pi)");
      }
      out_->cameras.push_back(cam);
    }
  }
  if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end() && it->second.Has("light")) {
    const int li = it->second.Get("light").GetNumberAsInt();
    if (li < 0 || li >= static_cast<int>(m_.lights.size()))
      fail(path_, node_at(index) + ": light " + std::to_string(li) + " is out of range");
    const tinygltf::Light& gl = m_.lights[li];
    LightDesc l;
    l.name = gl.name;
    Spectrum colour(1.0);
    if (gl.color.size() == 3) colour = Spectrum(gl.color[0], gl.color[1], gl.color[2]);
    l.intensity = colour * gl.intensity * out_->light_scale;
    l.position = glm::dvec3(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
    // A light shines down its local -Z (KHR_lights_punctual); point lights have no direction.
    const auto direction = unit(m3 * glm::dvec3(0.0, 0.0, -1.0));
    if (direction) l.direction = *direction;
    if (gl.type == "point") {
      l.type = LightType::kPoint;
    } else if (gl.type == "spot") {
      l.type = LightType::kSpot;
      l.cos_inner = std::cos(gl.spot.innerConeAngle);
      l.cos_outer = std::cos(gl.spot.outerConeAngle);
    } else if (gl.type == "directional") {
      l.type = LightType::kDirectional;
    } else {
      fail(path_, "light '" + gl.name + "' has unknown type '" + gl.type + "'");
    }
    if (l.type != LightType::kPoint && !direction)
      fail(path_, node_at(index) + ": light transform is degenerate (scale 0: its direction has length 0)");
    // Shadow rays start or end at a point or spot light: in float, for Embree.
    if (l.type != LightType::kDirectional && !fits_float(l.position))
      fail(path_, node_at(index) + ": light position is beyond the range of single precision (Embree traces in float)");
    if (gl.range > 0.0) warn("light range is ignored (physical inverse-square falloff is used)");
    if (!l.intensity.is_finite() || l.intensity.min() < 0.0) fail(path_, "light '" + gl.name + "' has an invalid intensity");
    out_->lights.push_back(l);
  }
  for (int child : node.children) visit(child, world, depth + 1);
}

void Loader::run() {
  out_->generator = m_.asset.generator;
  if (is_blender_generator(m_.asset.generator) && !m_.lights.empty()) {
    out_->light_scale = 1.0 / kBlenderLumensPerWatt;
    warn("exported by Blender (" + m_.asset.generator + "): light intensities divided by 683 lm/W, back to Blender's watts");
  }
  static const std::set<std::string> supported = {
      "KHR_lights_punctual",        "KHR_materials_emissive_strength",    "KHR_texture_transform",
      "KHR_materials_transmission", "KHR_materials_diffuse_transmission", "KHR_materials_volume",
      "KHR_materials_ior"};
  std::string unsupported;
  for (const std::string& e : m_.extensionsRequired)
    if (!supported.count(e)) fail(path_, "requires unsupported extension " + e);
  // One warning per material and extension it uses that is not read (naming both); the file's
  // other unsupported extensions (on nodes, meshes, textures, or unused) in one line.
  std::set<std::string> on_materials;
  for (const tinygltf::Material& gm : m_.materials)
    for (const auto& [e, value] : gm.extensions)
      if (!supported.count(e)) {
        warn("material '" + gm.name + "': extension " + e + " is not supported (ignored)");
        on_materials.insert(e);
      }
  for (const std::string& e : m_.extensionsUsed)
    if (!supported.count(e) && !on_materials.count(e)) unsupported += (unsupported.empty() ? "" : ", ") + e;
  if (!unsupported.empty()) warn("unsupported extensions ignored: " + unsupported);

  // Every texture becomes float RGB, 12 bytes a texel. Image sizes are known only once decoded
  // (validate_gltf cannot count them), so they are checked here against the same limit, before
  // any texture is converted.
  for (const tinygltf::Material& gm : m_.materials)
    if ((gm.alphaMode == "MASK" || gm.alphaMode == "BLEND") && gm.pbrMetallicRoughness.baseColorTexture.index >= 0)
      alpha_textures_.insert(gm.pbrMetallicRoughness.baseColorTexture.index);
  double texture_bytes = 0.0;
  for (std::size_t i = 0; i < m_.textures.size(); ++i) {
    const tinygltf::Texture& t = m_.textures[i];
    if (t.source >= 0 && t.source < static_cast<int>(m_.images.size()))
      texture_bytes += (alpha_textures_.count(static_cast<int>(i)) ? 16.0 : 12.0) *
                       std::max(m_.images[t.source].width, 0) * std::max(m_.images[t.source].height, 0);
  }
  if (texture_bytes > static_cast<double>(max_bytes_)) {
    std::ostringstream s;
    s.precision(3);
    s << "the textures need about " << texture_bytes / (1024.0 * 1024 * 1024) << " GiB decoded, more than the limit of "
      << static_cast<double>(max_bytes_) / (1024.0 * 1024 * 1024) << " GiB (LAMINA_MAX_SCENE_BYTES)";
    fail(path_, s.str());
  }

  // A textureInfo's texture coordinates: its texCoord set, and KHR_texture_transform on its
  // extensions (whose texCoord, when given, overrides the textureInfo's: the extension's README).
  // Sets 0 and 1 are read; a higher one is warned about and read as set 0.
  auto uv_transform = [&](const tinygltf::ExtensionMap& ext, int tex_coord, const std::string& material,
                          const char* slot) {
    auto it = ext.find("KHR_texture_transform");
    if (it != ext.end() && it->second.Has("texCoord") && it->second.Get("texCoord").IsNumber())
      tex_coord = it->second.Get("texCoord").GetNumberAsInt();
    auto with_set = [&](UvTransform t) {
      t.set = tex_coord == 1 ? 1 : 0;
      if (tex_coord < 0 || tex_coord > 1)
        warn("material '" + material + "': " + slot + " reads TEXCOORD_" + std::to_string(tex_coord) +
             ": only TEXCOORD_0 and TEXCOORD_1 are read, TEXCOORD_0 is used");
      return t;
    };
    if (it == ext.end()) return with_set(UvTransform{});
    const tinygltf::Value& v = it->second;
    auto number = [&](const tinygltf::Value& x, const char* what) {
      if (!x.IsNumber() || !std::isfinite(x.GetNumberAsDouble()))
        fail(path_, "material '" + material + "': KHR_texture_transform." + what + " must be a finite number");
      return x.GetNumberAsDouble();
    };
    auto pair = [&](const char* key, double fallback, double* x, double* y) {
      *x = *y = fallback;
      if (!v.Has(key)) return;
      const tinygltf::Value& p = v.Get(key);
      if (!p.IsArray() || p.ArrayLen() != 2)
        fail(path_, "material '" + material + "': KHR_texture_transform." + key + " must be an array of 2 numbers");
      *x = number(p.Get(0), key);
      *y = number(p.Get(1), key);
    };
    double ou, ov, su, sv;
    pair("offset", 0.0, &ou, &ov);
    pair("scale", 1.0, &su, &sv);
    const double rotation = v.Has("rotation") ? number(v.Get("rotation"), "rotation") : 0.0;
    return with_set(UvTransform::from(ou, ov, rotation, su, sv));
  };
  for (const tinygltf::Material& gm : m_.materials) {
    Material mat;
    const tinygltf::PbrMetallicRoughness& pbr = gm.pbrMetallicRoughness;
    if (pbr.baseColorTexture.index >= 0)
      mat.base_color_uv = uv_transform(pbr.baseColorTexture.extensions, pbr.baseColorTexture.texCoord, gm.name, "baseColorTexture");
    if (pbr.metallicRoughnessTexture.index >= 0)
      mat.metallic_roughness_uv = uv_transform(pbr.metallicRoughnessTexture.extensions, pbr.metallicRoughnessTexture.texCoord,
                                               gm.name, "metallicRoughnessTexture");
    if (gm.normalTexture.index >= 0)
      mat.normal_uv = uv_transform(gm.normalTexture.extensions, gm.normalTexture.texCoord, gm.name, "normalTexture");
    if (gm.emissiveTexture.index >= 0)
      mat.emissive_uv = uv_transform(gm.emissiveTexture.extensions, gm.emissiveTexture.texCoord, gm.name, "emissiveTexture");
    mat.name = gm.name;
    const std::vector<double>& bc = gm.pbrMetallicRoughness.baseColorFactor;
    if (bc.size() >= 3) mat.base_color = Spectrum(bc[0], bc[1], bc[2]);
    // alphaMode and alphaCutoff (glTF 2.0 section 3.9.4; defaults OPAQUE and 0.5).
    if (gm.alphaMode == "MASK") mat.alpha_mode = AlphaMode::kMask;
    else if (gm.alphaMode == "BLEND") mat.alpha_mode = AlphaMode::kBlend;
    else if (gm.alphaMode != "OPAQUE" && !gm.alphaMode.empty())
      fail(path_, "material '" + gm.name + "': alphaMode '" + gm.alphaMode + "' is not OPAQUE, MASK or BLEND");
    mat.alpha_cutoff = gm.alphaCutoff;
    mat.base_alpha = bc.size() == 4 ? bc[3] : 1.0;
    if (!(mat.alpha_cutoff >= 0.0) || !std::isfinite(mat.alpha_cutoff))
      fail(path_, "material '" + gm.name + "': alphaCutoff must be a finite number >= 0");
    if (!(mat.base_alpha >= 0.0 && mat.base_alpha <= 1.0))
      fail(path_, "material '" + gm.name + "': baseColorFactor's alpha must be in [0, 1]");
    mat.base_color_texture = texture(gm.pbrMetallicRoughness.baseColorTexture.index);
    double strength = 1.0;
    if (auto it = gm.extensions.find("KHR_materials_emissive_strength"); it != gm.extensions.end() &&
                                                                           it->second.Has("emissiveStrength"))
      strength = it->second.Get("emissiveStrength").GetNumberAsDouble();
    if (gm.emissiveFactor.size() == 3)
      mat.emission = Spectrum(gm.emissiveFactor[0], gm.emissiveFactor[1], gm.emissiveFactor[2]) * strength;
    mat.emissive_texture = texture(gm.emissiveTexture.index);
    mat.double_sided = gm.doubleSided;
    mat.metallic_roughness = true;
    mat.metallic = gm.pbrMetallicRoughness.metallicFactor;
    mat.roughness = gm.pbrMetallicRoughness.roughnessFactor;
    if (!std::isfinite(mat.metallic) || mat.metallic < 0.0 || mat.metallic > 1.0 || !std::isfinite(mat.roughness) ||
        mat.roughness < 0.0 || mat.roughness > 1.0)
      fail(path_, "material '" + gm.name + "': metallicFactor and roughnessFactor must be in [0, 1] (glTF 2.0 section 5.22)");
    mat.metallic_roughness_texture = texture(gm.pbrMetallicRoughness.metallicRoughnessTexture.index, true);
    mat.normal_texture = texture(gm.normalTexture.index, true);
    mat.normal_scale = gm.normalTexture.scale;
    if (!std::isfinite(mat.normal_scale)) fail(path_, "material '" + gm.name + "': normalTexture.scale must be finite");
    if (!mat.base_color.is_finite() || mat.base_color.min() < 0.0 || !mat.emission.is_finite() || mat.emission.min() < 0.0)
      fail(path_, "material '" + gm.name + "' has a negative or non-finite colour");
    read_transmissive(gm, &mat.transmissive);
    flatten_extras(gm.extras, "", &mat.extras);
    if (gm.extras.IsObject()) {
      std::ostringstream js;
      js.precision(17);
      write_json(gm.extras, &js);
      mat.extras_json = js.str();
    }
    out_->materials.push_back(std::move(mat));
  }

  for (int t = 0; t < static_cast<int>(m_.textures.size()); ++t) out_->gltf_textures[t] = texture(t);

  int scene = m_.defaultScene >= 0 ? m_.defaultScene : 0;
  if (m_.scenes.empty()) fail(path_, "has no scene");
  if (scene >= static_cast<int>(m_.scenes.size())) fail(path_, "default scene index is out of range");
  for (int n : m_.scenes[scene].nodes) visit(n, glm::dmat4(1.0), 0);
  if (out_->meshes.empty()) fail(path_, "the scene has no triangles to render");
  if (out_->degenerate_triangles > 0)
    warn(std::to_string(out_->degenerate_triangles) + " degenerate triangle(s) skipped");
  out_->compute_bounds();
}

}  // namespace

UvTransform UvTransform::from(double offset_u, double offset_v, double rotation, double scale_u, double scale_v) {
  UvTransform t;
  const double cr = std::cos(rotation), sr = std::sin(rotation);
  t.a = cr * scale_u;
  t.b = -sr * scale_v;
  t.c = offset_u;
  t.d = sr * scale_u;
  t.e = cr * scale_v;
  t.f = offset_v;
  return t;
}

Spectrum Texture::lookup(glm::dvec2 uv) const {
  BilinearFootprint f;
  if (!bilinear_footprint(uv, width, height, clamp_s, clamp_t, &f)) return Spectrum(0.0);
  Spectrum s;
  for (int k = 0; k < 4; ++k) {
    const float* p = &rgb[f.texel[k] * 3];
    s += Spectrum(p[0], p[1], p[2]) * f.weight[k];
  }
  return s;
}

double Texture::alpha_lookup(glm::dvec2 uv) const {
  if (alpha.empty()) return 1.0;
  BilinearFootprint f;
  if (!bilinear_footprint(uv, width, height, clamp_s, clamp_t, &f)) return 1.0;
  double a = 0.0;
  for (int k = 0; k < 4; ++k) a += alpha[f.texel[k]] * f.weight[k];
  return a;
}

const Material& SceneDesc::material(int index) const {
  // glTF's default material is white metal; Lamina has no metal, so the default is grey Lambert.
  static const Material kDefault{};
  return index >= 0 && index < static_cast<int>(materials.size()) ? materials[index] : kDefault;
}

void SceneDesc::compute_bounds() {
  const double inf = std::numeric_limits<double>::infinity();
  bounds_min = glm::dvec3(inf);
  bounds_max = glm::dvec3(-inf);
  for (const Mesh& m : meshes)
    for (std::uint32_t i : m.indices) {
      bounds_min = glm::min(bounds_min, glm::dvec3(m.positions[i]));
      bounds_max = glm::max(bounds_max, glm::dvec3(m.positions[i]));
    }
}

namespace {

// tinygltf's GetBaseDir: the directory it resolves a file's relative URIs against.
std::string tinygltf_base_dir(const std::string& path) {
  const std::size_t slash = path.find_last_of("/\\");
  return slash == std::string::npos ? std::string() : path.substr(0, slash);
}

// tinygltf reads external buffers and images through these callbacks. The default reader asks
// std::ifstream for the file's size before reading, which for a directory is about 2^63 (then
// std::bad_alloc), and reads a file of any size whole before comparing it with the byteLength.
// validate_gltf has refused such URIs already; this is the same rule at the one place tinygltf
// reads, for paths it found by its own search (the current directory after the file's own).
struct FileGuard {
  std::uint64_t max_bytes;
  std::vector<std::string>* read;  // every file read, in order
};
bool guarded_read(std::vector<unsigned char>* out, std::string* err, const std::string& file, void* user) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(file, ec);
  if (fs::exists(st) && !fs::is_regular_file(st)) {
    if (err) *err += fs::is_directory(st) ? "is a directory, not a file" : "is not a regular file";
    return false;
  }
  const std::uintmax_t size = fs::file_size(file, ec);
  if (!ec && size > static_cast<const FileGuard*>(user)->max_bytes) {
    if (err) *err += "is " + std::to_string(size) + " bytes, more than the scene memory limit (LAMINA_MAX_SCENE_BYTES)";
    return false;
  }
  static_cast<const FileGuard*>(user)->read->push_back(file);
  return tinygltf::ReadWholeFile(out, err, file, nullptr);
}
bool default_exists(const std::string& file, void*) { return tinygltf::FileExists(file, nullptr); }
std::string default_expand(const std::string& file, void*) { return tinygltf::ExpandFilePath(file, nullptr); }
bool refuse_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "the loader writes no files";
  return false;
}

SceneDesc load_validated(const std::string& path) {
  const bool binary = path.size() >= 4 && (path.compare(path.size() - 4, 4, ".glb") == 0 ||
                                           path.compare(path.size() - 4, 4, ".GLB") == 0);
  const std::uint64_t max_bytes = max_scene_bytes();
  // The validation layer, on the file's own JSON, before tinygltf reads it: the nesting depth
  // (tinygltf's conversion recurses), then the structure (gltf_validate.h).
  GltfText text;
  nlohmann::json doc;
  try {
    text = read_gltf_text(path, binary ? GltfFormat::kBinary : GltfFormat::kText);
    doc = parse_gltf_json(text, path);
  } catch (const GltfDocumentError& e) {
    throw SceneError(e.what());
  }
  const std::string base_dir = tinygltf_base_dir(path);
  validate_gltf(doc, path, base_dir, text.bytes.size(), max_bytes);
  doc = nlohmann::json();

  tinygltf::TinyGLTF loader;
  std::vector<std::string> files_read;
  FileGuard guard{max_bytes, &files_read};
  loader.SetFsCallbacks({&default_exists, &default_expand, &guarded_read, &refuse_write, &guard});
  tinygltf::Model model;
  std::string err, warn;
  // The same calls LoadBinaryFromFile and LoadASCIIFromFile make after reading the file.
  const bool ok =
      binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(text.bytes.data()),
                                           static_cast<unsigned int>(text.bytes.size()), base_dir)
             : loader.LoadASCIIFromString(&model, &err, &warn, text.bytes.data(),
                                          static_cast<unsigned int>(text.bytes.size()), base_dir);
  text = GltfText();
  if (!ok || !err.empty()) fail(path, err.empty() ? "cannot be read as glTF" : err);
  SceneDesc scene;
  scene.path = path;
  scene.files_read = std::move(files_read);
  if (!warn.empty()) scene.warnings.push_back(one_line(warn));
  Loader(path, model, &scene, max_bytes).run();
  return scene;
}

}  // namespace

SceneDesc load_gltf(const std::string& path) {
  // Sizes are checked before they are allocated (validate_gltf); whatever is still too large
  // for this machine (images, or a limit raised by LAMINA_MAX_SCENE_BYTES) ends here as one line
  // naming the file, not as an uncaught std::bad_alloc.
  try {
    return load_validated(path);
  } catch (const std::bad_alloc&) {
    throw SceneError(path + ": out of memory while loading the scene");
  } catch (const std::length_error& e) {
    throw SceneError(path + ": out of memory while loading the scene (" + std::string(e.what()) + ")");
  }
}

CameraDesc framing_camera(const SceneDesc& scene, double aspect) {
  CameraDesc cam;
  cam.name = "(framing)";
  cam.yfov = 40.0 * kPi / 180.0;
  const glm::dvec3 centre = 0.5 * (scene.bounds_min + scene.bounds_max);
  const glm::dvec3 half = 0.5 * (scene.bounds_max - scene.bounds_min);
  // Distance from the box's front face (+Z) at which its front fits the vertical and
  // horizontal field of view, plus 10% margin.
  const double t = std::tan(0.5 * cam.yfov);
  const double fit = 1.1 * std::max(half.y, half.x / std::max(aspect, 1e-6)) / t;
  cam.position = glm::dvec3(centre.x, centre.y, scene.bounds_max.z + std::max(fit, 1e-3));
  cam.forward = glm::dvec3(0.0, 0.0, -1.0);
  cam.up = glm::dvec3(0.0, 1.0, 0.0);
  return cam;
}

std::string light_strength_limit() {
  char text[64];
  std::snprintf(text, sizeof text, "%g (the image is float radiance, at most 3.4e38)", kMaxLightStrength);
  return text;
}

bool is_blender_generator(const std::string& generator) {
  return generator.rfind("Khronos glTF Blender I/O", 0) == 0;
}

}  // namespace lamina
