// Small glTF files written by the tests themselves: JSON built with nlohmann::json, buffers
// embedded as base64 data URIs (or written beside the file, or packed into a .glb).
#pragma once

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

namespace lamina::testing {

inline std::string base64(const std::vector<unsigned char>& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const std::uint32_t v = (in[i] << 16) | (in[i + 1] << 8) | in[i + 2];
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], k[v & 63]};
  }
  if (i + 1 == in.size()) {
    const std::uint32_t v = in[i] << 16;
    out += {k[v >> 18], k[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == in.size()) {
    const std::uint32_t v = (in[i] << 16) | (in[i + 1] << 8);
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], '='};
  }
  return out;
}

class GltfBuilder {
 public:
  GltfBuilder() {
    json_["asset"] = {{"version", "2.0"}};
    json_["scenes"] = nlohmann::json::array({{{"nodes", nlohmann::json::array()}}});
    json_["scene"] = 0;
    for (const char* k : {"nodes", "meshes", "accessors", "bufferViews", "materials"}) json_[k] = nlohmann::json::array();
  }
  nlohmann::json& json() { return json_; }

  // A float accessor of `comps` components per element (SCALAR/VEC2/VEC3/VEC4).
  int add_floats(const std::vector<float>& v, int comps) {
    const std::size_t offset = append(v.data(), v.size() * sizeof(float));
    json_["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", v.size() * sizeof(float)}});
    nlohmann::json acc = {{"bufferView", json_["bufferViews"].size() - 1},
                          {"componentType", 5126},
                          {"count", v.size() / comps},
                          {"type", comps == 1 ? "SCALAR" : comps == 2 ? "VEC2" : comps == 3 ? "VEC3" : "VEC4"}};
    json_["accessors"].push_back(acc);
    return static_cast<int>(json_["accessors"].size() - 1);
  }
  int add_indices(const std::vector<std::uint16_t>& v) {
    const std::size_t offset = append(v.data(), v.size() * 2);
    json_["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", v.size() * 2}});
    json_["accessors"].push_back(
        {{"bufferView", json_["bufferViews"].size() - 1}, {"componentType", 5123}, {"count", v.size()}, {"type", "SCALAR"}});
    return static_cast<int>(json_["accessors"].size() - 1);
  }
  // A mesh of one triangle primitive; returns the mesh index.
  int add_mesh(const std::vector<float>& positions, const std::vector<std::uint16_t>& indices = {},
               const std::vector<float>& normals = {}, int material = -1, int mode = 4) {
    nlohmann::json prim = {{"attributes", {{"POSITION", add_floats(positions, 3)}}}, {"mode", mode}};
    if (!indices.empty()) prim["indices"] = add_indices(indices);
    if (!normals.empty()) prim["attributes"]["NORMAL"] = add_floats(normals, 3);
    if (material >= 0) prim["material"] = material;
    json_["meshes"].push_back({{"primitives", nlohmann::json::array({prim})}});
    return static_cast<int>(json_["meshes"].size() - 1);
  }
  // Adds a node (to the scene's roots unless it is a child); returns its index.
  int add_node(nlohmann::json node, bool root = true) {
    json_["nodes"].push_back(std::move(node));
    const int i = static_cast<int>(json_["nodes"].size() - 1);
    if (root) json_["scenes"][0]["nodes"].push_back(i);
    return i;
  }

  // Writes a .gltf with the buffer embedded (or in `bin_name` beside it).
  void write_gltf(const std::string& path, const std::string& bin_name = "") {
    nlohmann::json j = json_;
    pad();
    if (bin_.empty()) {
      // no buffer at all
    } else if (bin_name.empty()) {
      j["buffers"] = {{{"byteLength", bin_.size()}, {"uri", "data:application/octet-stream;base64," + base64(bin_)}}};
    } else {
      j["buffers"] = {{{"byteLength", bin_.size()}, {"uri", bin_name}}};
      std::ofstream(std::filesystem::path(path).parent_path() / bin_name, std::ios::binary)
          .write(reinterpret_cast<const char*>(bin_.data()), static_cast<std::streamsize>(bin_.size()));
    }
    std::ofstream(path) << j.dump(1);
  }
  // Writes a .glb: header, JSON chunk, BIN chunk (glTF 2.0 section 4.4).
  void write_glb(const std::string& path) {
    nlohmann::json j = json_;
    pad();
    j["buffers"] = {{{"byteLength", bin_.size()}}};
    std::string text = j.dump();
    while (text.size() % 4) text += ' ';
    std::vector<unsigned char> out;
    auto u32 = [&](std::uint32_t v) { for (int i = 0; i < 4; ++i) out.push_back(static_cast<unsigned char>(v >> (8 * i))); };
    u32(0x46546C67);  // "glTF"
    u32(2);
    u32(static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + bin_.size()));
    u32(static_cast<std::uint32_t>(text.size()));
    u32(0x4E4F534A);  // "JSON"
    out.insert(out.end(), text.begin(), text.end());
    u32(static_cast<std::uint32_t>(bin_.size()));
    u32(0x004E4942);  // "BIN\0"
    out.insert(out.end(), bin_.begin(), bin_.end());
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size()));
  }

 private:
  std::size_t append(const void* data, std::size_t n) {
    pad();
    const std::size_t offset = bin_.size();
    bin_.resize(offset + n);
    std::memcpy(bin_.data() + offset, data, n);
    return offset;
  }
  void pad() { while (bin_.size() % 4) bin_.push_back(0); }
  nlohmann::json json_;
  std::vector<unsigned char> bin_;
};

// A fresh empty directory under the system temp dir, removed by the destructor.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& name) {
    path = std::filesystem::temp_directory_path() / ("lamina-test-" + name + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& file) const { return (path / file).string(); }
};

// A double-sided unit square in the z = 0 plane with one material "leaf" (green base colour):
// with `layered`, a thin-walled leaf (KHR_materials_diffuse_transmission 0.4), else a plain
// metallic-roughness material. Written to `path`.
inline void write_leaf_square(const std::string& path, bool layered) {
  GltfBuilder b;
  nlohmann::json ext = nlohmann::json::object();
  if (layered) ext = {{"KHR_materials_diffuse_transmission", {{"diffuseTransmissionFactor", 0.4}}}};
  b.json()["materials"].push_back({{"name", "leaf"},
                                   {"doubleSided", true},
                                   {"pbrMetallicRoughness", {{"baseColorFactor", {0.3, 0.5, 0.1, 1.0}}, {"metallicFactor", 0.0}}},
                                   {"extensions", ext}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0)}});
  b.write_gltf(path);
}

}  // namespace lamina::testing
