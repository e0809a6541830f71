// The validation layer of glTF input: the checks load_gltf (scene_gltf.h) makes on a file's JSON
// before tinygltf reads it and before anything is allocated by its sizes. Each refusal is a
// SceneError of one line naming the file and the JSON path or index: "FILE: nodes[3]: ...".
//
// What is checked here, and why it cannot wait for the loader:
// - the node hierarchy is a strict forest (glTF 2.0 spec, section 3.5.3 "Nodes and Hierarchy":
//   "the node hierarchy MUST be a set of disjoint strict trees"): a DAG or a cycle makes a
//   recursive traversal visit nodes exponentially often, or forever;
// - every index a node holds (children, mesh, camera, light) is in range (section 3.5.3 and
//   KHR_lights_punctual): a dangling camera index used to fall back to the framing camera;
// - buffers, buffer views and accessors fit inside one another (sections 3.6.1 "Buffers and
//   Buffer Views", 3.6.2 "Accessors"), and the files buffers and images name are regular files
//   of the stated size (a directory is read as a file of absurd size): checked before any count
//   is multiplied into an allocation;
// - the memory the scene needs, estimated from its accessors, is below max_scene_bytes();
// - cameras (section 5.14 "Camera Perspective": 0 < yfov < pi, aspectRatio > 0) and spot lights
//   (KHR_lights_punctual "Spot": 0 <= innerConeAngle < outerConeAngle <= pi/2);
// - a light's colour x intensity and a material's emissiveFactor x emissiveStrength are at most
//   kMaxLightStrength (scene_gltf.h): finite doubles beyond it overflow the float image to Inf.
// What needs the world transforms (finite, non-degenerate camera and light frames, vertex
// positions within float range) is checked by the loader as it walks the validated forest.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace lamina {

// The largest estimated scene memory load_gltf accepts: 8 GiB, or the environment variable
// LAMINA_MAX_SCENE_BYTES (a positive whole number of bytes). Throws SceneError naming the
// variable if it is set to anything else.
constexpr std::uint64_t kDefaultMaxSceneBytes = 8ull << 30;
std::uint64_t max_scene_bytes();

// Checks `gltf` (the parsed JSON of the file at `path`, `file_bytes` long) as listed above.
// `base_dir` is the directory tinygltf resolves relative URIs against (the file's own).
// Throws SceneError.
void validate_gltf(const nlohmann::json& gltf, const std::string& path, const std::string& base_dir,
                   std::uint64_t file_bytes, std::uint64_t max_bytes);

// tinygltf's resolution of an external URI: percent-decoded (its dlib::urldecode, which also
// reads '+' as a space), then joined to `base_dir`, then to ".": the first that exists, or "".
std::string tinygltf_resolve_uri(const std::string& uri, const std::string& base_dir);

}  // namespace lamina
