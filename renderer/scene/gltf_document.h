// The JSON of a glTF 2.0 file, read without loading the scene (no tinygltf, no buffers decoded,
// no images read): what batch manifests check a scene against and hash it by. The glTF
// material names, the names `lamina render --camera` accepts, and the external files (buffers,
// images) the file references. load_gltf (scene_gltf.h) reads the whole scene; it names cameras
// with camera_display_name, and gltf_camera_names accepts every name that rule can give.
#pragma once

#include <cstddef>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace lamina {

// Thrown with one line: "<file>: <problem>".
struct GltfDocumentError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The bytes of a glTF file, and where its JSON is in them: the whole file for a .gltf, the JSON
// chunk for a .glb (glTF 2.0 spec, section 4.4 "GLB File Format Specification").
struct GltfText {
  std::string bytes;            // the whole file
  std::size_t json_offset = 0;  // the JSON: bytes[json_offset, json_offset + json_length)
  std::size_t json_length = 0;
  bool binary = false;          // a GLB
  std::string_view json() const { return std::string_view(bytes).substr(json_offset, json_length); }
};

// How read_gltf_text tells .gltf from .glb: by the GLB magic "glTF" at the start (kDetect), or as
// the caller says (load_gltf goes by the file's extension, as tinygltf's entry points do).
enum class GltfFormat { kDetect, kText, kBinary };

// Reads a glTF file and finds its JSON. Throws GltfDocumentError when the path is not a regular
// file (a directory is read by std::ifstream as a file of absurd size), cannot be read, or is a
// GLB whose header or JSON chunk is cut short.
GltfText read_gltf_text(const std::string& path, GltfFormat format = GltfFormat::kDetect);

// The JSON of `text` as an object. The nesting depth is checked first (materials/stack/json_limits.h:
// no parser or recursive walk sees JSON nested deeper than kMaxJsonNesting), the error naming
// the byte of the file. Throws GltfDocumentError when the JSON nests too deep, is invalid, or is
// not an object.
nlohmann::json parse_gltf_json(const GltfText& text, const std::string& path);

// read_gltf_text then parse_gltf_json: the JSON part of a .gltf, or the JSON chunk of a .glb, as
// an object.
nlohmann::json read_gltf_json(const std::string& path);

// The names of the glTF materials ("materials"[i].name; unnamed ones are left out).
std::set<std::string> gltf_material_names(const nlohmann::json& gltf);

// The name a camera is known by (CameraDesc::name): its own name, or, since a camera's name is
// optional (glTF 2.0 spec, Properties Reference, "Camera": "name" is not required), the name of
// the node that places it in the scene ("Node": "camera").
std::string camera_display_name(const std::string& camera_name, const std::string& node_name);

// Camera names `lamina render --camera` accepts (renderer/cli/render.cpp find_camera matches a
// CameraDesc's name or its node's name): every named camera's name, and the name of every named
// node that has a camera. An unnamed camera's camera_display_name is its node's name, so this
// holds every name the loader can give a camera and its node. It is lenient where the loader
// is not: cameras no node of the default scene instances, and orthographic ones (which the
// loader skips), count too.
std::set<std::string> gltf_camera_names(const nlohmann::json& gltf);

// A file outside the glTF that the scene's pixels depend on.
struct GltfExternalFile {
  std::string list;  // "buffers" or "images": the array it is listed in
  std::string uri;   // as written in the file
  std::string path;  // the file (below)
};
// The buffers, then the images, with a "uri" that is not a data: URI (embedded data is in the
// file's own bytes), in file order (glTF 2.0 spec, Properties Reference, "Buffer" and "Image":
// a relative "uri" is relative to the .gltf file). `path` is the file the loader reads
// (tinygltf_resolve_uri, gltf_validate.h), or where the URI points if no such file exists.
std::vector<GltfExternalFile> gltf_external_files(const nlohmann::json& gltf, const std::string& gltf_path);

// "%20" and friends in glTF URIs decoded (RFC 3986 percent-encoding; glTF 2.0 spec, "URIs"). A
// '%' not followed by two hex digits is kept as it is.
std::string percent_decode(const std::string& uri);

}  // namespace lamina
