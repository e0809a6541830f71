// The JSON of a glTF 2.0 file (see gltf_document.h).
#include "renderer/scene/gltf_document.h"

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "materials/stack/json_limits.h"
#include "materials/stack/text_file.h"
#include "renderer/scene/gltf_validate.h"

namespace lamina {

namespace fs = std::filesystem;
using nlohmann::json;

GltfText read_gltf_text(const std::string& path, GltfFormat format) {
  GltfText t;
  {
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (fs::exists(st) && !fs::is_regular_file(st))
      throw GltfDocumentError(path + ": " + (fs::is_directory(st) ? "is a directory" : "is not a regular file") +
                              ", not a glTF file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw GltfDocumentError(path + ": cannot read the file: " + file_unreadable_reason(path));
    std::ostringstream s;
    s << in.rdbuf();
    if (in.bad()) throw GltfDocumentError(path + ": read error");
    t.bytes = s.str();
  }
  // glTF 2.0 spec, "GLB File Format Specification": a 12-byte header (magic "glTF", version,
  // length), then chunks of (length, type, data); the first chunk is the JSON one, type 'JSON'.
  const bool magic = t.bytes.size() >= 4 && t.bytes.compare(0, 4, "glTF") == 0;
  t.binary = format == GltfFormat::kBinary || (format == GltfFormat::kDetect && magic);
  t.json_length = t.bytes.size();
  if (t.binary) {
    if (!magic) throw GltfDocumentError(path + ": not a GLB file (it does not start with the magic 'glTF')");
    if (t.bytes.size() < 20) throw GltfDocumentError(path + ": truncated GLB header");
    std::uint32_t length = 0, type = 0;
    std::memcpy(&length, t.bytes.data() + 12, 4);  // GLB is little-endian, as is every host we build on
    std::memcpy(&type, t.bytes.data() + 16, 4);
    if (type != 0x4E4F534Au || 20ull + length > t.bytes.size()) throw GltfDocumentError(path + ": GLB without a JSON chunk");
    t.json_offset = 20;
    t.json_length = length;
  }
  return t;
}

json parse_gltf_json(const GltfText& text, const std::string& path) {
  // Before parsing: tinygltf converts the document recursively, so deep nesting (in extras,
  // say) would overflow the stack; the offset named is the file's (the JSON chunk's start
  // added in a GLB).
  if (const auto deep = json_nesting_exceeds(text.json()))
    throw GltfDocumentError(path + ": " + json_nesting_message(text.json_offset + *deep));
  json j;
  const std::string why = parse_json_text(text.json(), &j);  // parse_error, and numbers like 1e999 with their path
  if (!why.empty()) throw GltfDocumentError(path + ": not a glTF file: " + why);
  if (!j.is_object()) throw GltfDocumentError(path + ": not a glTF file (the JSON is not an object)");
  return j;
}

json read_gltf_json(const std::string& path) { return parse_gltf_json(read_gltf_text(path), path); }

std::set<std::string> gltf_material_names(const json& gltf) {
  std::set<std::string> names;
  if (gltf.contains("materials") && gltf["materials"].is_array())
    for (const json& m : gltf["materials"])
      if (m.contains("name") && m["name"].is_string()) names.insert(m["name"].get<std::string>());
  return names;
}

std::string camera_display_name(const std::string& camera_name, const std::string& node_name) {
  return camera_name.empty() ? node_name : camera_name;
}

std::set<std::string> gltf_camera_names(const json& gltf) {
  // A named camera is known by its own name wherever it is placed (camera_display_name gives
  // it back unchanged); an unnamed one by its node's name, which find_camera accepts for a
  // named camera too. So: every camera name, and the name of every node with a camera.
  std::set<std::string> names;
  if (gltf.contains("cameras") && gltf["cameras"].is_array())
    for (const json& c : gltf["cameras"])
      if (c.contains("name") && c["name"].is_string()) names.insert(c["name"].get<std::string>());
  if (gltf.contains("nodes") && gltf["nodes"].is_array())
    for (const json& n : gltf["nodes"])
      if (n.contains("camera") && n.contains("name") && n["name"].is_string()) names.insert(n["name"].get<std::string>());
  return names;
}

std::vector<GltfExternalFile> gltf_external_files(const json& gltf, const std::string& gltf_path) {
  std::vector<GltfExternalFile> files;
  const fs::path dir = fs::path(gltf_path).parent_path();
  for (const char* list : {"buffers", "images"}) {
    if (!gltf.contains(list) || !gltf[list].is_array()) continue;
    for (const json& item : gltf[list]) {
      if (!item.contains("uri") || !item["uri"].is_string()) continue;  // a GLB's own buffer, or an image in a bufferView
      const std::string uri = item["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;  // embedded: already in the file's bytes
      // The file the loader reads (its search: the glTF's directory, then the working one), or,
      // if there is none, where the glTF says it is.
      const std::string found = tinygltf_resolve_uri(uri, dir.string());
      files.push_back({list, uri, found.empty() ? (dir / percent_decode(uri)).string() : found});
    }
  }
  return files;
}

std::string percent_decode(const std::string& uri) {
  std::string out;
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += static_cast<char>(std::strtol(uri.substr(i + 1, 2).c_str(), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

}  // namespace lamina
