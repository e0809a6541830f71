#include "renderer/layered/layered_material.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "materials/random_walk.h"
#include "materials/sampling.h"
#include "materials/stack_file.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/layered/stack_bindings.h"

namespace lamina {

bool parse_subsurface_mode(const std::string& name, SubsurfaceMode* mode) {
  if (name == "random-walk") *mode = SubsurfaceMode::RandomWalk;
  else if (name == "first-order") *mode = SubsurfaceMode::FirstOrder;
  else if (name == "table") *mode = SubsurfaceMode::Table;
  else if (name == "lambert") *mode = SubsurfaceMode::Lambert;
  else return false;
  return true;
}

const char* subsurface_mode_name(SubsurfaceMode mode) {
  switch (mode) {
    case SubsurfaceMode::RandomWalk: return "random-walk";
    case SubsurfaceMode::FirstOrder: return "first-order";
    case SubsurfaceMode::Table: return "table";
    case SubsurfaceMode::Lambert: return "lambert";
  }
  return "?";
}

Spectrum diffuse_bihemispherical_albedo(const LayerStack& stack, int walks, std::uint64_t seed,
                                        Spectrum* standard_error) {
  // Cosine-weighted incidence: mu_i = sqrt(u) has density 2 mu_i on [0, 1], so
  // E[top exit weight after >= 1 scattering] = int_0^1 R_diffuse(mu) 2 mu dmu, the white-sky
  // albedo. The walk's weight is per unit incident power and excludes the top's specular part.
  Spectrum sum(0.0), sum2(0.0);
  for (int i = 0; i < walks; ++i) {
    Rng rng(seed, static_cast<std::uint64_t>(i), 0x1a3b);
    const double mu = std::sqrt(std::max(rng.uniform(), 1e-300));
    const double phi = 2.0 * kPi * rng.uniform();
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    const WalkResult r = random_walk(stack, {s * std::cos(phi), s * std::sin(phi), mu}, rng);
    if (r.side == WalkResult::Side::Top && r.scatter_count > 0) {
      sum += r.weight;
      sum2 += r.weight * r.weight;
    }
  }
  const double n = std::max(1, walks);
  const Spectrum mean = sum / n;
  if (standard_error) {
    for (int c = 0; c < kChannels; ++c)
      (*standard_error)[c] = std::sqrt(std::max(0.0, sum2[c] / n - mean[c] * mean[c]) / std::max(1.0, n - 1.0));
  }
  return mean;
}

LayeredMaterial::LayeredMaterial(LayerStack stack, std::string source, int albedo_walks)
    : stack_(std::move(stack)), source_(std::move(source)), albedo_walks_(albedo_walks) {
  if (stack_.transmits()) flipped_ = flipped(stack_);
}

const Spectrum& LayeredMaterial::lambert_albedo() const {
  // Computed once per material, on first use.
  std::call_once(albedo_once_, [this] {
    lambert_albedo_ = diffuse_bihemispherical_albedo(stack_, albedo_walks_, kAlbedoSeed, &lambert_albedo_stderr_);
    albedo_state_ = 1;
  });
  return lambert_albedo_;
}

bool LayeredMaterial::preset_lambert_albedo(const Spectrum& albedo, const Spectrum& standard_error) const {
  bool set = false;
  std::call_once(albedo_once_, [&] {
    lambert_albedo_ = albedo;
    lambert_albedo_stderr_ = standard_error;
    albedo_state_ = 2;
    set = true;
  });
  return set;
}

const Spectrum& LayeredMaterial::lambert_albedo_stderr() const {
  lambert_albedo();
  return lambert_albedo_stderr_;
}

LayeredMaterial::LayeredMaterial(LayerStack stack, std::string source, std::shared_ptr<const StackBindings> bindings)
    : LayeredMaterial(std::move(stack), std::move(source)) {
  if (bindings && !bindings->empty()) bindings_ = std::move(bindings);
}

const LayerStack& LayeredMaterial::stack_at(const ShadingPoint& sp, StackScratch& scratch) const {
  if (bindings_) {
    // Texture-driven parameters: the stack at this uv, built in the caller's scratch (no
    // allocation once its vectors have grown; stack_bindings.h).
    bindings_->evaluate(sp.uv, &scratch.stack);
    if (!(sp.from_below && stack_.transmits())) return scratch.stack;
    // Seen from below: the same as flipped() (materials/stack.h), by copy-assignment so the
    // scratch's storage is reused.
    LayerStack& f = scratch.flipped;
    f = scratch.stack;
    std::reverse(f.layers.begin(), f.layers.end());
    f.above_ior = scratch.stack.below.ior;
    f.below.ior = scratch.stack.above_ior;
    return f;
  }
  if (sp.from_below && stack_.transmits()) return flipped_;
  return stack_;
}

int LayeredBindings::count() const {
  int n = 0;
  for (const auto& m : by_material) n += m != nullptr;
  return n;
}

namespace {

std::string resolve(const std::string& path, const std::string& relative_to_file) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  if (p.is_absolute()) return p.string();
  return (fs::path(relative_to_file).parent_path() / p).lexically_normal().string();
}

// `spec` (may be null) holds "bind" / "freckles" (renderer/layered/stack_bindings.h); `scene` resolves
// glTF texture indices. Materials with the same stack and the same bindings share one object.
std::shared_ptr<const LayeredMaterial> load_bound(const std::string& named_in, const std::string& material,
                                                  const std::string& stack_path, const std::string& resolved,
                                                  std::map<std::string, std::shared_ptr<const LayeredMaterial>>* cache,
                                                  const nlohmann::json& spec = nullptr, const SceneDesc* scene = nullptr) {
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
    throw SceneError(e.what());
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

LayeredBindings bind_layered_materials(const SceneDesc& scene, const std::string& map_path) {
  LayeredBindings out;
  out.by_material.resize(scene.materials.size());
  std::map<std::string, std::shared_ptr<const LayeredMaterial>> cache;  // one material per file

  std::map<std::string, std::string> map;  // glTF material name -> stack path as written
  std::map<std::string, nlohmann::json> map_specs;  // entries given as objects (with bindings)
  if (!map_path.empty()) {
    std::ifstream in(map_path);
    if (!in) throw SceneError(map_path + ": cannot read the material map");
    std::stringstream ss;
    ss << in.rdbuf();
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(ss.str());
    } catch (const nlohmann::json::exception& e) {
      throw SceneError(map_path + ": not valid JSON (" + std::string(e.what()) + ")");
    }
    if (!j.is_object()) throw SceneError(map_path + ": expected an object {\"glTF material name\": \"stack.json\", ...}");
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.value().is_object()) {
        if (!it.value().contains("stack") || !it.value()["stack"].is_string())
          throw SceneError(map_path + ": " + it.key() + ".stack: expected the path of a stack file (a string)");
        for (auto k = it.value().begin(); k != it.value().end(); ++k)
          if (k.key() != "stack" && k.key() != "bind" && k.key() != "freckles")
            throw SceneError(map_path + ": " + it.key() + "." + k.key() + ": unknown key (allowed: stack, bind, freckles)");
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
      if (!found) throw SceneError(map_path + ": " + name + ": no material of that name in " + scene.path);
    }
  }

  for (std::size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    if (auto it = map.find(m.name); it != map.end()) {
      const auto spec = map_specs.find(m.name);
      out.by_material[i] = load_bound(map_path, m.name, it->second, resolve(it->second, map_path), &cache,
                                      spec == map_specs.end() ? nlohmann::json(nullptr) : spec->second, &scene);
    } else if (auto e = m.extras.find("lamina.stack"); e != m.extras.end()) {
      nlohmann::json spec = nullptr;
      if (!m.extras_json.empty()) {
        const nlohmann::json extras = nlohmann::json::parse(m.extras_json, nullptr, false);
        if (extras.is_object() && extras.contains("lamina") && extras["lamina"].is_object()) spec = extras["lamina"];
        // A misspelt key ("frekles") must not be silently ignored.
        for (auto k = spec.begin(); spec.is_object() && k != spec.end(); ++k)
          if (k.key() != "stack" && k.key() != "bind" && k.key() != "freckles")
            throw SceneError(scene.path + ": material '" + m.name + "': extras.lamina." + k.key() +
                             ": unknown key (allowed: stack, bind, freckles)");
      }
      out.by_material[i] = load_bound(scene.path, m.name, e->second, resolve(e->second, scene.path), &cache, spec, &scene);
    }
  }
  return out;
}

}  // namespace lamina
