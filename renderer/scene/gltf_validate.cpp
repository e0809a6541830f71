// The validation layer of glTF input (see gltf_validate.h).
#include "renderer/scene/gltf_validate.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <set>
#include <vector>

#include "materials/base/sampling.h"
#include "renderer/scene/scene_gltf.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string at(const std::string& list, std::size_t i) { return list + "[" + std::to_string(i) + "]"; }

// A number as the file may have written it ("1.5", not std::to_string's "1.500000").
std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", x);
  return buf;
}

// "2.5 GiB": sizes in messages.
std::string bytes_text(double b) {
  char buf[64];
  if (b >= 1024.0 * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.1f GiB", b / (1024.0 * 1024 * 1024));
  else if (b >= 1024.0 * 1024) std::snprintf(buf, sizeof buf, "%.1f MiB", b / (1024.0 * 1024));
  else std::snprintf(buf, sizeof buf, "%.0f bytes", b);
  return buf;
}

class Validator {
 public:
  Validator(const json& g, const std::string& path, const std::string& base_dir)
      : g_(g), path_(path), base_dir_(base_dir) {}

  void run(std::uint64_t file_bytes, std::uint64_t max_bytes) {
    buffers();
    buffer_views();
    accessors();
    images();
    cameras();
    lights();
    emission();
    alpha_cutoffs();
    morph_weights();
    nodes();
    forest();
    memory(file_bytes, max_bytes);
  }

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw SceneError(path_ + ": " + where + ": " + what);
  }

  // The top-level array `key` (empty if absent); anything else is refused.
  const json& list(const json& obj, const char* key, const std::string& where) const {
    static const json kEmpty = json::array();
    if (!obj.is_object() || !obj.contains(key)) return kEmpty;
    const json& v = obj[key];
    if (!v.is_array()) fail(where.empty() ? key : where + "." + key, "expected an array, got " + std::string(v.type_name()));
    return v;
  }
  const json& top(const char* key) const { return list(g_, key, ""); }

  // A non-negative whole number (an index, a count, a length in bytes), or nullopt if absent.
  // JSON numbers are doubles to many writers, so 3.0 counts as 3.
  std::optional<std::uint64_t> whole(const json& obj, const char* key, const std::string& where) const {
    if (!obj.is_object() || !obj.contains(key)) return std::nullopt;
    const json& v = obj[key];
    if (v.is_number_unsigned()) return v.get<std::uint64_t>();
    if (v.is_number_float()) {
      const double d = v.get<double>();
      if (d >= 0.0 && d < 18446744073709551616.0 && std::floor(d) == d) return static_cast<std::uint64_t>(d);
    }
    fail(where + "." + key, "expected a non-negative integer, got " + v.dump());
  }
  std::uint64_t required(const json& obj, const char* key, const std::string& where) const {
    const auto v = whole(obj, key, where);
    if (!v) fail(where, std::string("has no \"") + key + "\" (it is required)");
    return *v;
  }
  // An index into the top-level array `list` of `n` items.
  std::optional<std::uint64_t> index(const json& obj, const char* key, const std::string& where, std::size_t n,
                                     const char* what) const {
    const auto i = whole(obj, key, where);
    if (i && *i >= n) fail(where, std::string(what) + " " + std::to_string(*i) + " is out of range (the file has " +
                                      std::to_string(n) + ")");
    return i;
  }
  std::optional<double> number(const json& obj, const char* key, const std::string& where) const {
    if (!obj.is_object() || !obj.contains(key)) return std::nullopt;
    const json& v = obj[key];
    if (!v.is_number()) fail(where + "." + key, "expected a number, got " + v.dump());
    return v.get<double>();
  }

  // Buffers (glTF 2.0 spec, section 3.6.1 "Buffers and Buffer Views"): byteLength is
  // required; an external file must be a regular file of exactly that length (tinygltf refuses
  // any other length, but only after reading the whole file, and reads a directory as a file of
  // about 2^63 bytes).
  void buffers() {
    const json& bs = top("buffers");
    for (std::size_t k = 0; k < bs.size(); ++k) {
      const std::string w = at("buffers", k);
      buffer_length_.push_back(required(bs[k], "byteLength", w));
      // A data: URI holds at most 3 bytes per 4 base64 characters (RFC 4648 section 4); a
      // larger byteLength would only inflate the memory estimate below.
      if (bs[k].is_object() && bs[k].contains("uri") && bs[k]["uri"].is_string()) {
        const std::string& uri = bs[k]["uri"].get_ref<const std::string&>();
        const std::size_t comma = uri.find(',');
        if (uri.rfind("data:", 0) == 0 && comma != std::string::npos &&
            buffer_length_.back() > (uri.size() - comma - 1) / 4 * 3 + 3)
          fail(w, "byteLength " + std::to_string(buffer_length_.back()) + " is more than its data: URI holds");
      }
      if (const auto file = external_file(bs[k], w)) {
        std::error_code ec;
        const std::uintmax_t size = fs::file_size(*file, ec);
        if (!ec && size != buffer_length_.back())
          fail(w, "'" + bs[k]["uri"].get<std::string>() + "' has " + std::to_string(size) +
                      " bytes, but the buffer's byteLength is " + std::to_string(buffer_length_.back()));
      }
    }
  }
  // The regular file an item's non-data "uri" names, resolved as tinygltf does; nullopt for a
  // data: URI, no URI, or a file that does not exist (tinygltf then says so with the URI).
  std::optional<std::string> external_file(const json& item, const std::string& w) const {
    if (!item.is_object() || !item.contains("uri")) return std::nullopt;
    if (!item["uri"].is_string()) fail(w + ".uri", "expected a string, got " + item["uri"].dump());
    const std::string uri = item["uri"].get<std::string>();
    if (uri.rfind("data:", 0) == 0) return std::nullopt;
    const std::string file = tinygltf_resolve_uri(uri, base_dir_);
    if (file.empty()) return std::nullopt;
    std::error_code ec;
    const fs::file_status st = fs::status(file, ec);
    if (!fs::is_regular_file(st))
      fail(w + ".uri", "'" + uri + "' is " + (fs::is_directory(st) ? "a directory" : "not a regular file") + ", not a file");
    return file;
  }
  void images() {
    const json& is = top("images");
    for (std::size_t k = 0; k < is.size(); ++k) external_file(is[k], at("images", k));
  }

  // Buffer views (section 3.6.1): the bytes [byteOffset, byteOffset + byteLength) lie in the
  // buffer.
  void buffer_views() {
    const json& vs = top("bufferViews");
    for (std::size_t v = 0; v < vs.size(); ++v) {
      const std::string w = at("bufferViews", v);
      const auto b = index(vs[v], "buffer", w, buffer_length_.size(), "buffer");
      if (!b) fail(w, "has no \"buffer\" (it is required)");
      const std::uint64_t offset = whole(vs[v], "byteOffset", w).value_or(0);
      const std::uint64_t length = required(vs[v], "byteLength", w);
      if (offset > buffer_length_[*b] || length > buffer_length_[*b] - offset)
        fail(w, "bytes " + std::to_string(offset) + " + " + std::to_string(length) + " run past the end of buffers[" +
                    std::to_string(*b) + "] (" + std::to_string(buffer_length_[*b]) + " bytes)");
      view_length_.push_back(length);
      view_stride_.push_back(whole(vs[v], "byteStride", w).value_or(0));
    }
  }
  // `count` elements of `elem` bytes, `stride` apart (0: tightly packed), from `offset` in
  // buffer view `view`, must end inside the view (section 3.6.2.4: "each accessor MUST fit its
  // bufferView"). Computed without overflow: count and offset come straight from the file.
  void fits_view(const std::string& w, std::uint64_t view, std::uint64_t offset, std::uint64_t count,
                 std::uint64_t elem, const char* what) const {
    if (count == 0) return;
    const std::uint64_t stride = view_stride_[view] ? view_stride_[view] : elem;
    const std::uint64_t length = view_length_[view];
    // offset + (count - 1) * stride + elem <= length, term by term.
    const bool fits = offset <= length && elem <= length - offset &&
                      (count - 1) <= (stride == 0 ? count : (length - offset - elem) / stride);
    if (!fits)
      fail(w, std::to_string(count) + " " + what + " of " + std::to_string(elem) + " bytes (stride " +
                  std::to_string(stride) + ") from byteOffset " + std::to_string(offset) + " do not fit in bufferViews[" +
                  std::to_string(view) + "] (" + std::to_string(length) + " bytes)");
  }

  static int component_size(std::uint64_t type) {
    switch (type) {
      case 5120: case 5121: return 1;  // BYTE, UNSIGNED_BYTE
      case 5122: case 5123: return 2;  // SHORT, UNSIGNED_SHORT
      case 5125: case 5126: return 4;  // UNSIGNED_INT, FLOAT
      default: return 0;
    }
  }
  static int components(const std::string& type) {
    static const std::pair<const char*, int> k[] = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                     {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
    for (const auto& [name, n] : k)
      if (type == name) return n;
    return 0;
  }

  // Accessors (section 3.6.2): a known component type and type, a count, and every element
  // (and every sparse index and value) inside its buffer view. The loader reads elements
  // tightly packed as components x component size (matrix column padding is not modelled), and
  // so is the check.
  void accessors() {
    const json& as = top("accessors");
    for (std::size_t a = 0; a < as.size(); ++a) {
      const std::string w = at("accessors", a);
      const json& acc = as[a];
      const std::uint64_t ctype = required(acc, "componentType", w);
      const int csize = component_size(ctype);
      if (!csize) fail(w + ".componentType", std::to_string(ctype) + " is not a glTF component type");
      if (!acc.contains("type") || !acc["type"].is_string()) fail(w, "has no \"type\" string (it is required)");
      const int comps = components(acc["type"].get<std::string>());
      if (!comps) fail(w + ".type", "'" + acc["type"].get<std::string>() + "' is not a glTF accessor type");
      const std::uint64_t count = required(acc, "count", w);
      const std::uint64_t elem = static_cast<std::uint64_t>(comps) * csize;
      if (const auto view = index(acc, "bufferView", w, view_length_.size(), "bufferView"))
        fits_view(w, *view, whole(acc, "byteOffset", w).value_or(0), count, elem, "elements");
      if (acc.contains("sparse")) {
        const json& sp = acc["sparse"];
        const std::string ws = w + ".sparse";
        const std::uint64_t n = required(sp, "count", ws);
        // Section 3.6.2.3: the sparse elements substitute some of the accessor's own.
        if (n > count) fail(ws + ".count", std::to_string(n) + " is more than the accessor's count " + std::to_string(count));
        const json empty = json::object();
        const json& ind = sp.contains("indices") ? sp["indices"] : empty;
        const json& val = sp.contains("values") ? sp["values"] : empty;
        const std::uint64_t itype = required(ind, "componentType", ws + ".indices");
        if (itype != 5121 && itype != 5123 && itype != 5125)
          fail(ws + ".indices.componentType", std::to_string(itype) + " is not an unsigned integer type");
        const auto iview = index(ind, "bufferView", ws + ".indices", view_length_.size(), "bufferView");
        const auto vview = index(val, "bufferView", ws + ".values", view_length_.size(), "bufferView");
        if (!iview) fail(ws + ".indices", "has no \"bufferView\" (it is required)");
        if (!vview) fail(ws + ".values", "has no \"bufferView\" (it is required)");
        fits_view(ws + ".indices", *iview, whole(ind, "byteOffset", ws + ".indices").value_or(0), n,
                  static_cast<std::uint64_t>(component_size(itype)), "indices");
        fits_view(ws + ".values", *vview, whole(val, "byteOffset", ws + ".values").value_or(0), n, elem, "values");
      }
      accessor_count_.push_back(count);
    }
  }

  // Cameras (section 5.14 "Camera Perspective"): yfov is required, "exclusiveMinimum": 0,
  // and "SHOULD be less than pi" (at pi the image plane is infinitely wide and tan(yfov/2)
  // gives infinite ray directions); aspectRatio, where given, "exclusiveMinimum": 0.
  void cameras() {
    const json& cs = top("cameras");
    for (std::size_t c = 0; c < cs.size(); ++c) {
      const std::string w = at("cameras", c);
      if (cs[c].is_object() && cs[c].value("type", "") == "orthographic") {
        // Section 5.16 "Camera Orthographic": xmag and ymag are required and MUST NOT be zero;
        // zfar MUST be greater than znear (znear >= 0).
        if (!cs[c].contains("orthographic")) fail(w, "is orthographic but has no \"orthographic\" object");
        const json& o = cs[c]["orthographic"];
        const std::string wo = w + ".orthographic";
        for (const char* key : {"xmag", "ymag"}) {
          const auto v = number(o, key, wo);
          if (!v) fail(wo, std::string("has no \"") + key + "\" (it is required)");
          if (!(*v != 0.0 && std::isfinite(*v))) fail(wo + "." + key, num(*v) + " must be a non-zero finite number");
        }
        continue;
      }
      if (!cs[c].is_object() || cs[c].value("type", "") != "perspective" || !cs[c].contains("perspective")) continue;
      const json& p = cs[c]["perspective"];
      const std::string wp = w + ".perspective";
      const auto yfov = number(p, "yfov", wp);
      if (!yfov) fail(wp, "has no \"yfov\" (it is required)");
      if (!(*yfov > 0.0 && *yfov < kPi)) fail(wp + ".yfov", num(*yfov) + " is not in (0, pi)");
      if (const auto aspect = number(p, "aspectRatio", wp); aspect && !(*aspect > 0.0 && std::isfinite(*aspect)))
        fail(wp + ".aspectRatio", num(*aspect) + " is not positive");
    }
  }

  // Punctual lights (KHR_lights_punctual, "Spot"): innerConeAngle "Must be greater than or equal
  // to 0 and less than outerConeAngle", outerConeAngle "Must be greater than innerConeAngle and
  // less than or equal to PI / 2.0" (defaults 0 and pi/4). An inverted cone rendered a hard
  // edge. pi/2 rounded to float (1.5707963705..., what a float exporter writes) counts as pi/2.
  // Equal angles are accepted although the extension asks for inner < outer: Blender's exporter
  // writes them for a spot blend of 0, meaning a hard edge, which is what the falloff gives
  // (renderer/render/lights.cpp bounds its ramp's width).
  void lights() {
    const json* exts = g_.is_object() && g_.contains("extensions") ? &g_["extensions"] : nullptr;
    if (!exts || !exts->is_object() || !exts->contains("KHR_lights_punctual")) return;
    const json& ls = list((*exts)["KHR_lights_punctual"], "lights", "extensions.KHR_lights_punctual");
    light_count_ = ls.size();
    for (std::size_t l = 0; l < ls.size(); ++l) {
      if (ls[l].is_object())  // color defaults to white
        check_strength(ls[l].contains("color") ? ls[l]["color"] : json::array({1.0}), ls[l], "intensity",
                       "extensions.KHR_lights_punctual." + at("lights", l), "color x intensity");
      if (!ls[l].is_object() || ls[l].value("type", "") != "spot" || !ls[l].contains("spot")) continue;
      const std::string w = "extensions.KHR_lights_punctual." + at("lights", l) + ".spot";
      const double inner = number(ls[l]["spot"], "innerConeAngle", w).value_or(0.0);
      const double outer = number(ls[l]["spot"], "outerConeAngle", w).value_or(kPi / 4.0);
      const double half_pi = static_cast<double>(static_cast<float>(kPi / 2.0));
      if (!(inner >= 0.0 && inner <= outer && outer > 0.0 && outer <= half_pi))
        fail(w, "innerConeAngle " + num(inner) + " and outerConeAngle " + num(outer) +
                    " do not satisfy 0 <= inner <= outer <= pi/2, outer > 0");
    }
  }

  // Emissive materials: emissiveFactor (default 0) x KHR_materials_emissive_strength's
  // emissiveStrength (default 1) is the surface's radiance, at most kMaxLightStrength.
  void emission() {
    const json& ms = top("materials");
    for (std::size_t m = 0; m < ms.size(); ++m) {
      if (!ms[m].is_object() || !ms[m].contains("emissiveFactor")) continue;
      const json& ext = ms[m].contains("extensions") ? ms[m]["extensions"] : json();
      const json& strength = ext.is_object() && ext.contains("KHR_materials_emissive_strength")
                                 ? ext["KHR_materials_emissive_strength"]
                                 : json();
      check_strength(ms[m]["emissiveFactor"], strength, "emissiveStrength", at("materials", m),
                     "emissiveFactor x emissiveStrength");
    }
  }

  // alphaCutoff (section 5.19 "Material"): a number. tinygltf replaced any other type (a string
  // "0.3") by the default 0.5 without a word.
  void alpha_cutoffs() {
    const json& ms = top("materials");
    for (std::size_t m = 0; m < ms.size(); ++m) number(ms[m], "alphaCutoff", at("materials", m));
  }

  // Morph weights (section 3.7.2.2 "Morph Targets"): a mesh's or a node's `weights` hold one
  // weight per morph target, and so its mesh's primitives MUST have that many targets. Weights
  // on a mesh without targets were ignored without a word (with targets, the loader refuses a
  // wrong count naming the primitive).
  void morph_weights() {
    const json& meshes = top("meshes");
    auto has_targets = [&](std::size_t mesh) {
      if (mesh >= meshes.size() || !meshes[mesh].is_object() || !meshes[mesh].contains("primitives")) return true;  // left to the loader
      for (const json& p : meshes[mesh]["primitives"])
        if (p.is_object() && p.contains("targets") && p["targets"].is_array() && !p["targets"].empty()) return true;
      return false;
    };
    for (std::size_t m = 0; m < meshes.size(); ++m)
      if (meshes[m].is_object() && meshes[m].contains("weights") && meshes[m]["weights"].is_array() &&
          !meshes[m]["weights"].empty() && !has_targets(m))
        fail(at("meshes", m) + ".weights", "the mesh has " + std::to_string(meshes[m]["weights"].size()) +
                                                " morph weight(s) but no morph targets (one weight per target)");
    const json& nodes = top("nodes");
    for (std::size_t n = 0; n < nodes.size(); ++n) {
      const json& node = nodes[n];
      if (!node.is_object() || !node.contains("weights") || !node["weights"].is_array() || node["weights"].empty()) continue;
      if (!node.contains("mesh") || !node["mesh"].is_number_unsigned())
        fail(at("nodes", n) + ".weights", "morph weights on a node without a mesh (one weight per morph target of its mesh)");
      if (!has_targets(node["mesh"].get<std::size_t>()))
        fail(at("nodes", n) + ".weights", "the node has " + std::to_string(node["weights"].size()) + " morph weight(s) but mesh " +
                                              std::to_string(node["mesh"].get<std::size_t>()) + " has no morph targets");
    }
  }

  // The largest channel of `colour` (an array of numbers) times the number `scale_key` of
  // `scale_obj` (default 1) must be at most kMaxLightStrength (scene_gltf.h). Values of the wrong
  // type are left to the loader's messages.
  void check_strength(const json& colour, const json& scale_obj, const char* scale_key, const std::string& where,
                      const char* what) const {
    double largest = 0.0;
    if (colour.is_array())
      for (const json& x : colour)
        if (x.is_number()) largest = std::max(largest, x.get<double>());
    const double scale = scale_obj.is_object() && scale_obj.contains(scale_key) && scale_obj[scale_key].is_number()
                             ? scale_obj[scale_key].get<double>()
                             : 1.0;
    if (const double value = largest * scale; value > kMaxLightStrength)
      fail(where, std::string(what) + " is " + num(value) + ", above the largest light strength, " +
                      light_strength_limit());
  }

  // The indices a node holds (section 5.25 "Node"), and its rotation: a quaternion of length 0
  // is no rotation (the loader normalises the others, exporters write them off unit length).
  void nodes() {
    const json& ns = top("nodes");
    parent_.assign(ns.size(), -1);
    node_mesh_.assign(ns.size(), -1);
    const std::size_t meshes = top("meshes").size(), cameras = top("cameras").size();
    for (std::size_t i = 0; i < ns.size(); ++i) {
      const std::string w = at("nodes", i);
      const json& n = ns[i];
      if (!n.is_object()) fail(w, "expected an object, got " + std::string(n.type_name()));
      if (const auto m = index(n, "mesh", w, meshes, "mesh")) node_mesh_[i] = static_cast<std::int64_t>(*m);
      index(n, "camera", w, cameras, "camera");
      if (n.contains("extensions") && n["extensions"].is_object() && n["extensions"].contains("KHR_lights_punctual"))
        index(n["extensions"]["KHR_lights_punctual"], "light", w, light_count_, "light");
      if (n.contains("rotation") && n["rotation"].is_array()) {
        bool zero = true;
        for (const json& x : n["rotation"]) zero = zero && x.is_number() && x.get<double>() == 0.0;
        if (zero && n["rotation"].size() == 4) fail(w + ".rotation", "a quaternion of length 0 is not a rotation");
      }
      // Section 3.5.3: each node has at most one parent, and lists no child twice.
      const json& children = list(n, "children", w);
      for (std::size_t k = 0; k < children.size(); ++k) {
        const json& cj = children[k];
        if (!cj.is_number_unsigned() || cj.get<std::uint64_t>() >= ns.size())
          fail(w + ".children", "node " + cj.dump() + " is out of range (the file has " + std::to_string(ns.size()) + ")");
        const auto c = cj.get<std::size_t>();
        if (parent_[c] == static_cast<std::int64_t>(i)) fail(w + ".children", "node " + std::to_string(c) + " is listed twice");
        if (parent_[c] >= 0)
          fail(at("nodes", c), "is a child of both nodes[" + std::to_string(parent_[c]) + "] and " + w +
                                   " (the node hierarchy must be a set of disjoint strict trees)");
        parent_[c] = static_cast<std::int64_t>(i);
      }
    }
  }

  // Section 3.5.3: no node is its own ancestor, and the roots of a scene have no parent and are
  // listed once. With one parent per node (nodes()), following parents from every node finds
  // each cycle in time linear in the node count: a walk that meets its own mark has looped.
  void forest() {
    std::vector<std::size_t> mark(parent_.size(), 0);
    for (std::size_t s = 0; s < parent_.size(); ++s) {
      std::int64_t x = static_cast<std::int64_t>(s);
      while (x >= 0 && mark[x] == 0) {
        mark[x] = s + 1;
        x = parent_[x];
      }
      if (x >= 0 && mark[x] == s + 1)
        fail(at("nodes", static_cast<std::size_t>(x)), "is its own ancestor (the node hierarchy has a cycle; it must be "
                                                       "a set of disjoint strict trees)");
    }
    const json& scenes = top("scenes");
    for (std::size_t s = 0; s < scenes.size(); ++s) {
      const std::string w = at("scenes", s) + ".nodes";
      std::set<std::uint64_t> seen;
      for (const json& r : list(scenes[s], "nodes", at("scenes", s))) {
        if (!r.is_number_unsigned() || r.get<std::uint64_t>() >= parent_.size())
          fail(w, "node " + r.dump() + " is out of range (the file has " + std::to_string(parent_.size()) + ")");
        const auto n = r.get<std::size_t>();
        if (!seen.insert(n).second) fail(w, "node " + std::to_string(n) + " is listed twice");
        if (parent_[n] >= 0)
          fail(w, "node " + std::to_string(n) + " is a child of nodes[" + std::to_string(parent_[n]) +
                      "], so it cannot be a root");
      }
    }
  }

  // The memory a scene needs, estimated before loading from its accessors (docs/contracts.md,
  // lamina render): the file; every buffer (tinygltf holds them all); for every instance of a
  // TRIANGLES primitive in the default scene (each node naming its mesh), its vertices and
  // indices as the loader stores them (float positions, normals and texture coordinates,
  // 32-bit indices) and as Embree copies them (positions and indices); and the decoding of the
  // largest primitive in double precision. Images and Embree's BVH are not counted. An
  // accessor without a buffer view (zeros, section 3.6.2.3) is bounded by nothing else.
  void memory(std::uint64_t file_bytes, std::uint64_t max_bytes) {
    const json& scenes = top("scenes");
    const std::uint64_t scene = whole(g_, "scene", "").value_or(0);
    if (scene >= scenes.size()) return;  // the loader refuses it
    // Instances per mesh: the default scene's forest, walked without recursion.
    std::vector<std::uint64_t> instances(top("meshes").size(), 0);
    const json& ns = top("nodes");
    std::vector<std::size_t> stack;
    for (const json& r : list(scenes[scene], "nodes", at("scenes", scene))) stack.push_back(r.get<std::size_t>());
    while (!stack.empty()) {
      const std::size_t n = stack.back();
      stack.pop_back();
      if (node_mesh_[n] >= 0) ++instances[static_cast<std::size_t>(node_mesh_[n])];
      for (const json& c : list(ns[n], "children", at("nodes", n))) stack.push_back(c.get<std::size_t>());
    }
    double total = static_cast<double>(file_bytes), decode = 0.0, largest = 0.0;
    for (std::uint64_t b : buffer_length_) total += static_cast<double>(b);
    std::string largest_where;
    const json& meshes = top("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      if (!instances[m]) continue;
      const json& prims = list(meshes[m], "primitives", at("meshes", m));
      for (std::size_t p = 0; p < prims.size(); ++p) {
        const std::string w = at("meshes", m) + "." + at("primitives", p);
        const json& prim = prims[p];
        // TRIANGLES (4), TRIANGLE_STRIP (5) and TRIANGLE_FAN (6) become triangles; the others are skipped.
        const auto mode = whole(prim, "mode", w).value_or(4);
        if (mode < 4 || mode > 6 || !prim.contains("attributes")) continue;
        const json& attrs = prim["attributes"];
        auto count = [&](const json& obj, const char* key, const std::string& where) -> std::optional<double> {
          const auto a = index(obj, key, where, accessor_count_.size(), "accessor");
          if (!a) return std::nullopt;
          return static_cast<double>(accessor_count_[*a]);
        };
        const auto v = count(attrs, "POSITION", w + ".attributes");
        if (!v) continue;
        // Vertex indices are 32-bit (Mesh::indices, Embree's UINT3 triangles).
        if (*v > 4294967295.0)
          fail(w + ".attributes.POSITION", "has " + std::to_string(static_cast<std::uint64_t>(*v)) +
                                               " vertices, more than 32-bit indices can address");
        const double normals = count(attrs, "NORMAL", w + ".attributes").has_value() ? 1.0 : 0.0;
        const double uvs = count(attrs, "TEXCOORD_0", w + ".attributes").has_value() ? 1.0 : 0.0;
        const double read = count(prim, "indices", w).value_or(*v);
        const double i = mode == 4 ? read : 3.0 * std::max(0.0, read - 2.0);  // a strip's or fan's triangle list
        const double stored = *v * (12.0 + 12.0 * normals + 8.0 * uvs) + 4.0 * i;
        const double embree = *v * 12.0 + 4.0 * i;
        const double part = static_cast<double>(instances[m]) * (stored + embree);
        total += part;
        decode = std::max(decode, *v * 8.0 * (3.0 + 3.0 * normals + 2.0 * uvs) + 12.0 * i);
        if (part > largest) {
          largest = part;
          largest_where = w + " (" + std::to_string(static_cast<std::uint64_t>(*v)) + " vertices x " +
                          std::to_string(instances[m]) + " instance" + (instances[m] == 1 ? "" : "s") + ")";
        }
      }
    }
    total += decode;
    if (total > static_cast<double>(max_bytes))
      throw SceneError(path_ + ": loading needs about " + bytes_text(total) + " (estimated from the accessors" +
                       (largest_where.empty() ? std::string() : "; the largest part is " + largest_where) +
                       "), more than the limit of " + bytes_text(static_cast<double>(max_bytes)) +
                       " (LAMINA_MAX_SCENE_BYTES)");
  }

  const json& g_;
  const std::string& path_;
  const std::string& base_dir_;
  std::vector<std::uint64_t> buffer_length_, view_length_, view_stride_, accessor_count_;
  std::size_t light_count_ = 0;
  std::vector<std::int64_t> parent_, node_mesh_;
};

// tinygltf 2.7's dlib::urldecode: '+' is a space, '%' with two more characters is a byte (a
// non-hex digit reads as 0).
std::string tinygltf_urldecode(const std::string& s) {
  auto hex = [](unsigned char c) -> unsigned char {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return 0;
  };
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%' && s.size() > i + 2) {
      out += static_cast<char>((hex(static_cast<unsigned char>(s[i + 1])) << 4) | hex(static_cast<unsigned char>(s[i + 2])));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

// tinygltf's JoinPath.
std::string join_path(const std::string& a, const std::string& b) {
  if (a.empty()) return b;
  const char last = a.back();
  return last == '/' || last == '\\' ? a + b : a + "/" + b;
}

}  // namespace

std::string tinygltf_resolve_uri(const std::string& uri, const std::string& base_dir) {
  const std::string decoded = tinygltf_urldecode(uri);
  if (decoded.empty()) return "";
  for (const std::string& dir : {base_dir, std::string(".")}) {
    const std::string p = join_path(dir, decoded);
    std::error_code ec;
    if (fs::exists(p, ec)) return p;
  }
  return "";
}

std::uint64_t max_scene_bytes() {
  const char* env = std::getenv("LAMINA_MAX_SCENE_BYTES");
  if (!env) return kDefaultMaxSceneBytes;
  const std::string s(env);
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(s.c_str(), &end, 10);
  if (s.empty() || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }) || errno == ERANGE ||
      v == 0)
    throw SceneError("LAMINA_MAX_SCENE_BYTES='" + s + "': expected a positive whole number of bytes");
  return v;
}

void validate_gltf(const json& gltf, const std::string& path, const std::string& base_dir, std::uint64_t file_bytes,
                   std::uint64_t max_bytes) {
  Validator(gltf, path, base_dir).run(file_bytes, max_bytes);
}

}  // namespace lamina
