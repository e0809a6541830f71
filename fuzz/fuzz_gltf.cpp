// The glTF 2.0 loader (renderer/scene/scene_gltf): .gltf text or .glb binary (by the magic).
#include <cstring>

#include "fuzz/fuzz_input.h"
#include "renderer/scene/scene_gltf.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  const std::string path = lamina::fuzz::input_file(data, size, glb ? ".glb" : ".gltf");
  return lamina::fuzz::refuse_cleanly([&] { lamina::load_gltf(path); });
}
