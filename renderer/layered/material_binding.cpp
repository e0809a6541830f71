#include "renderer/layered/material_binding.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "materials/stack/stack_file.h"
#include "materials/stack/stack_parameters.h"
#include "renderer/layered/gltf_stack.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/wavelength_stack.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/util/paths.h"
#include "materials/stack/json_keys.h"
#include "materials/stack/json_limits.h"
#include "materials/stack/text_file.h"

namespace lamina {

namespace {

// The keys of a stack binding, in a material map entry or a material's extras.lamina.
constexpr std::initializer_list<const char*> kBindingKeys = {"stack", "bind", "freckles"};


// The scene's material names for a message: 'a', 'b' in glTF order, each once; "none".
std::string material_names(const SceneDesc& scene) {
  std::string names;
  std::set<std::string> seen;
  for (const Material& m : scene.materials)
    if (seen.insert(m.name).second) names += (names.empty() ? "'" : ", '") + m.name + "'";
  return names.empty() ? "none" : names;
}

// `spec` (may be null) holds "bind" / "freckles" (renderer/layered/stack_bindings.h); `scene` resolves
// glTF texture indices. Materials with the same stack and the same bindings share one object.
std::shared_ptr<const LayeredMaterial> load_bound(const std::string& named_in, const std::string& material,
                                                  const std::string& stack_path, const std::string& resolved,
                                                  std::map<std::string, std::shared_ptr<const LayeredMaterial>>* cache,
                                                  const nlohmann::json& spec = nullptr, const SceneDesc* scene = nullptr,
                                                  bool spectral = false) {
  const bool bound = spec.is_object() && (spec.contains("bind") || spec.contains("freckles"));
  const std::string key = bound ? resolved + "\n" + named_in + "\n" + spec.dump() : resolved;
  if (auto it = cache->find(key); it != cache->end()) return it->second;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(resolved, ec))
    throw SceneError(named_in + ": material '" + material + "': stack file '" + stack_path + "' not found (" + resolved + ")");
  StackTemplate stack;
  try {
    stack = load_stack_template(resolved);
  } catch (const StackFileError& e) {
    // The spectral mode reads leaf layers, which the RGB reader refuses (wavelength_stack.h).
    std::optional<StackTemplate> leaf = spectral ? leaf_stack(resolved) : std::nullopt;
    if (!leaf) throw SceneError(e.what());
    stack = std::move(*leaf);
  }
  std::shared_ptr<const LayeredMaterial> m;
  if (bound) {
    auto t = std::make_shared<const StackTemplate>(stack);
    auto b = std::make_shared<const StackBindings>(spec, t, *scene, named_in, material, named_in);
    m = std::make_shared<const LayeredMaterial>(std::move(stack.stack), resolved, std::move(b));
  } else {
    m = std::make_shared<const LayeredMaterial>(std::move(stack.stack), resolved);
  }
  (*cache)[key] = m;
  return m;
}

}  // namespace

void adopt_meshes_without_material(const std::vector<StackAssignment>& stacks, SceneDesc* scene) {
  bool all = false;
  for (const StackAssignment& a : stacks) all |= a.all();
  if (!all) return;
  int slot = -1;
  for (Mesh& mesh : scene->meshes) {
    if (mesh.material >= 0 && mesh.material < static_cast<int>(scene->materials.size())) continue;
    if (slot < 0) {
      Material none = scene->material(-1);
      none.name = kNoMaterialName;
      scene->materials.push_back(none);
      slot = static_cast<int>(scene->materials.size()) - 1;
    }
    mesh.material = slot;
  }
}

namespace {

// --stack's assignments by material ("" for all), checked against the scene's names.
std::map<std::string, std::string> stacks_by_material(const SceneDesc& scene, const std::vector<StackAssignment>& stacks) {
  std::map<std::string, std::string> out;
  for (const StackAssignment& a : stacks) {
    if (!a.all()) {
      bool found = false;
      std::string names;
      for (const Material& m : scene.materials) {
        found |= m.name == a.material;
        if (m.name != kNoMaterialName) names += (names.empty() ? "'" : ", '") + m.name + "'";
      }
      if (!found)
        throw SceneError(std::string(kStackFlag) + " '" + stack_assignment_text(a) + "': no material '" + a.material + "' in " +
                         scene.path + " (its materials: " + (names.empty() ? "none" : names) + ")");
    }
    out[a.material] = a.path;
  }
  return out;
}

}  // namespace

namespace {

// The stack of a material's glTF extensions; with KHR_materials_volume's thicknessTexture, its
// layer's thickness is a texture-driven parameter: the texture's G channel t gives thickness
// t x (the thickness from thicknessFactor), so the optical depth scales with it as the
// extension's thickness does (stack_bindings.h; docs/gltf_materials.md).
std::shared_ptr<const LayeredMaterial> gltf_layered_material(const SceneDesc& scene, const Material& m) {
  const std::string source = scene.path + "#" + m.name + " (glTF extensions)";
  LayerStack stack = gltf_stack(m, scene.path);
  const Material::Transmissive& t = m.transmissive;
  if (t.thickness_texture < 0 || !(t.volume && t.thickness > 0.0))
    return std::make_shared<const LayeredMaterial>(std::move(stack), source);
  auto templ = std::make_shared<StackTemplate>();
  templ->stack = stack;
  for (const Layer& layer : stack.layers) {
    LayerDesc desc;
    desc.components.push_back(ComponentDesc{1.0, layer.sigma_a, layer.sigma_s(), layer.lobes.empty() ? Spectrum(0.0) : layer.lobes[0].g});
    templ->layers.push_back(desc);
  }
  const nlohmann::json spec = {{"bind",
                                {{{"parameter", "layers[0].thickness"},
                                  {"texture", t.thickness_texture},
                                  {"channel", "g"},
                                  {"range", {0.0, stack.layers[0].thickness}}}}}};
  auto bindings = std::make_shared<const StackBindings>(spec, templ, scene, scene.path, m.name, scene.path);
  return std::make_shared<const LayeredMaterial>(std::move(stack), source, std::move(bindings));
}

}  // namespace

LayeredBindings bind_layered_materials(const SceneDesc& scene, const std::string& map_path,
                                       const std::vector<InlineStack>& inline_stacks,
                                       const std::vector<StackAssignment>& stacks, bool spectral) {
  const std::map<std::string, std::string> assigned = stacks_by_material(scene, stacks);
  LayeredBindings out;
  out.by_material.resize(scene.materials.size());
  std::map<std::string, std::shared_ptr<const LayeredMaterial>> cache;  // one material per file

  std::map<std::string, std::string> map;  // glTF material name -> stack path as written
  std::map<std::string, nlohmann::json> map_specs;  // entries given as objects (with bindings)
  if (!map_path.empty()) {
    std::ifstream in(map_path);
    if (const std::string why = file_unreadable_reason(map_path); !why.empty())
      throw SceneError(map_path + ": cannot read the material map: " + why);
    if (!in) throw SceneError(map_path + ": cannot read the material map");
    std::stringstream ss;
    ss << in.rdbuf();
    // Bounded before parsing and parsed as every JSON input (materials/stack/json_limits.h).
    nlohmann::json j;
    const std::string why = parse_json_text(ss.str(), &j);
    if (!why.empty()) throw SceneError(map_path + ": " + why);
    if (!j.is_object()) throw SceneError(map_path + ": expected an object {\"glTF material name\": \"stack.json\", ...}");
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.value().is_object()) {
        if (!it.value().contains("stack") || !it.value()["stack"].is_string())
          throw SceneError(map_path + ": " + it.key() + ".stack: expected the path of a stack file (a string)");
        if (const std::string* key = first_unknown_key(it.value(), kBindingKeys))
          throw SceneError(map_path + ": " + it.key() + "." + *key + ": unknown key (allowed: " + key_list(kBindingKeys) + ")");
        map[it.key()] = it.value()["stack"].get<std::string>();
        map_specs[it.key()] = it.value();
        continue;
      }
      if (!it.value().is_string())
        throw SceneError(map_path + ": " + it.key() + ": expected the path of a stack file (a string) or an object {\"stack\": ...}");
      map[it.key()] = it.value().get<std::string>();
    }
    for (const auto& [name, path] : map) {
      bool found = false;
      for (const Material& m : scene.materials) found |= m.name == name;
      if (!found)
        throw SceneError(map_path + ": " + name + ": no material of that name in " + scene.path + " (materials: " +
                         material_names(scene) + ")");
    }
  }

  std::map<std::string, const InlineStack*> inline_by_name;
  for (const InlineStack& st : inline_stacks) {
    bool found = false;
    for (const Material& m : scene.materials) found |= m.name == st.material;
    if (!found)
      throw SceneError(st.source + ": " + st.material + ": no material of that name in " + scene.path + " (materials: " +
                       material_names(scene) + ")");
    inline_by_name[st.material] = &st;
  }

  for (std::size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    if (auto in = inline_by_name.find(m.name); in != inline_by_name.end()) {
      const InlineStack& st = *in->second;
      auto& slot = cache[st.source];
      if (!slot) {
        try {
          StackTemplate stack = parse_stack_template_json(st.json, st.source);
          slot = std::make_shared<const LayeredMaterial>(std::move(stack.stack), st.source);
        } catch (const StackFileError& e) {
          throw SceneError(e.what());
        }
      }
      out.by_material[i] = slot;
    } else if (auto st = assigned.count(m.name) ? assigned.find(m.name) : assigned.find(""); st != assigned.end()) {
      out.by_material[i] = load_bound(kStackFlag, m.name, st->second, st->second, &cache, nullptr, nullptr, spectral);
    } else if (auto it = map.find(m.name); it != map.end()) {
      const auto spec = map_specs.find(m.name);
      out.by_material[i] = load_bound(map_path, m.name, it->second, resolve_relative_to(it->second, map_path), &cache,
                                      spec == map_specs.end() ? nlohmann::json(nullptr) : spec->second, &scene, spectral);
    } else if (auto e = m.extras.find("lamina.stack"); e != m.extras.end()) {
      nlohmann::json spec = nullptr;
      if (!m.extras_json.empty()) {
        const nlohmann::json extras = nlohmann::json::parse(m.extras_json, nullptr, false);
        if (extras.is_object() && extras.contains("lamina") && extras["lamina"].is_object()) spec = extras["lamina"];
        // A misspelt key ("frekles") must not be silently ignored.
        if (const std::string* key = first_unknown_key(spec, kBindingKeys))
          throw SceneError(scene.path + ": material '" + m.name + "': extras.lamina." + *key +
                           ": unknown key (allowed: " + key_list(kBindingKeys) + ")");
      }
      out.by_material[i] = load_bound(scene.path, m.name, e->second, resolve_relative_to(e->second, scene.path), &cache, spec, &scene,
                                      spectral);
    } else if (has_gltf_stack(m)) {
      // glTF transmission, diffuse transmission, volume and IOR as a stack (gltf_stack.h).
      out.by_material[i] = gltf_layered_material(scene, m);
    }
  }
  return out;
}

}  // namespace lamina
