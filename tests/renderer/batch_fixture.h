// Tiny batch inputs written by the tests: a Lambert quad lit by the environment, with a glTF
// material "skin" and a camera "front", small layer stacks, and manifests.
#pragma once

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/renderer/gltf_fixture.h"

namespace lamina::testing {

// A 2 x 2 quad facing +Z at the origin, material "skin" (base colour 0.8, 0.5, 0.4), camera
// "front" at z = 3 looking down -Z. `bin_name`: write the buffer beside the file.
inline void write_batch_quad(const std::string& path, const std::string& bin_name = "", float red = 0.8f) {
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "skin"}, {"pbrMetallicRoughness", {{"baseColorFactor", {red, 0.5, 0.4, 1.0}}}}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0)}});
  b.json()["cameras"] = {{{"name", "front"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.01}}}}};
  b.add_node({{"name", "front_node"}, {"camera", 0}, {"translation", {0.0, 0.0, 3.0}}});
  b.write_gltf(path, bin_name);
}

// A two-layer stack in the contract's format; the second layer has two components.
inline nlohmann::json small_stack() {
  return nlohmann::json::parse(R"({
    "lamina_material": 1, "name": "test", "above_ior": 1.0,
    "layers": [
      { "name": "top", "ior": 1.4, "thickness": 0.1, "sigma_a": [0.1, 0.2, 0.3], "sigma_s": 10.0, "g": 0.5 },
      { "name": "bottom", "ior": 1.4, "thickness": 1.0,
        "components": [
          { "fraction": 0.1, "sigma_a": [1.0, 20.0, 30.0], "sigma_s": 15.0, "g": 0.8 },
          { "fraction": 0.3, "sigma_a": 0.05, "sigma_s": 15.0, "g": 0.8 },
          { "fraction": 0.6, "sigma_a": 0.02, "sigma_s": 20.0, "g": 0.0 } ] } ],
    "below": { "lambert": 0.5 } })");
}

inline void write_json(const std::string& path, const nlohmann::json& j) { std::ofstream(path) << j.dump(2); }

}  // namespace lamina::testing
