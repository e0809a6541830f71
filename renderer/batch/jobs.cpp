// Batch jobs: expansion, hashing, stack overrides, comparisons and shards (see jobs.h).
#include "renderer/batch/jobs.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "materials/stack/json_limits.h"
#include "materials/stack/stack_parameters.h"
#include "materials/stack/text_file.h"
#include "renderer/render/spectral_option.h"
#include "renderer/batch/manifest_where.h"
#include "renderer/scene/gltf_document.h"
#include "renderer/util/version.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using batch_detail::Where;

std::string read_bytes(const std::string& path) {
  std::string text;
  const std::string why = read_text_file(path, &text);  // materials/stack/text_file.h: says why
  if (!why.empty()) throw ManifestError(path + ": cannot read the file: " + why);
  return text;
}

}  // namespace

std::string file_hash(const std::string& path) { return content_hash(read_bytes(path)); }

// The pixels depend on the buffers and images as much as on the .gltf, so their bytes are hashed
// too; data: URIs and a GLB's own buffer are already in the file's bytes.
std::string scene_hash(const std::string& path, std::vector<std::string>* files) {
  json gltf;
  try {
    gltf = read_gltf_json(path);
  } catch (const GltfDocumentError& e) {
    throw ManifestError(e.what());  // the same one line: "<file>: <problem>"
  }
  std::string all = "file " + file_hash(path) + "\n";
  for (const GltfExternalFile& f : gltf_external_files(gltf, path)) {
    std::error_code ec;
    if (!fs::is_regular_file(f.path, ec)) throw ManifestError(path + ": " + f.list + " uri '" + f.uri + "' names no file");
    all += f.uri + " " + file_hash(f.path) + "\n";
    if (files) files->push_back(f.path);
  }
  return content_hash(all);
}

void apply_stack_override(json& stack, const MaterialOverride& ov, const std::string& where_text) {
  const Where where{where_text, ""};
  // layer index -> the component indices whose fraction was set
  std::map<std::size_t, std::set<std::size_t>> set_fractions;
  for (const StackSetting& s : ov.set) {
    const std::vector<StackPathStep> steps = batch_detail::stack_path_steps(s.path, where);
    try {
      *find_stack_value(stack, steps, s.path) = s.value;
    } catch (const StackParameterError& e) {
      where.fail(e.what());
    }
    if (steps.size() == 5 && steps[0].key == "layers" && steps[1].key.empty() && steps[2].key == "components" &&
        steps[3].key.empty() && steps[4].key == "fraction")
      set_fractions[steps[1].index].insert(steps[3].index);
  }
  if (!ov.renormalise) return;
  // Rescale the fractions not set so the layer's fractions sum to 1: with S the sum of the set
  // ones and O that of the others, each other fraction is multiplied by (1 - S) / O.
  for (const auto& [layer, set] : set_fractions) {
    json& components = stack["layers"][layer]["components"];
    double s = 0.0, o = 0.0;
    for (std::size_t c = 0; c < components.size(); ++c) {
      const json& f = components[c]["fraction"];
      if (!f.is_number()) where.fail("layers[" + std::to_string(layer) + "].components[" + std::to_string(c) + "].fraction is not a number");
      (set.count(c) ? s : o) += f.get<double>();
    }
    const std::string lw = "renormalise layers[" + std::to_string(layer) + "]: ";
    if (s < 0.0 || s > 1.0 + 1e-12) where.fail(lw + "the fractions set sum to " + json(s).dump() + ", more than 1");
    if (o <= 0.0) {
      if (std::abs(s - 1.0) > 1e-6) where.fail(lw + "no other component to rescale and the fractions set sum to " + json(s).dump());
      continue;
    }
    const double scale = (1.0 - s) / o;
    for (std::size_t c = 0; c < components.size(); ++c)
      if (!set.count(c)) components[c]["fraction"] = components[c]["fraction"].get<double>() * scale;
  }
}

std::vector<BatchJob> expand_jobs(const Manifest& m) {
  // Hash each input file once, however many jobs use it.
  std::map<std::string, std::string> scene_hashes, env_hashes;
  std::map<std::string, std::vector<std::string>> scene_files;  // the buffers and images of each
  std::map<std::string, json> stacks;
  auto stack_json = [&](const std::string& file) -> const json& {
    auto it = stacks.find(file);
    if (it != stacks.end()) return it->second;
    json j;
    const std::string why = parse_json_text(read_bytes(file), &j);
    if (!why.empty()) throw ManifestError(file + ": " + why);
    if (!j.is_object()) throw ManifestError(file + ": not a material file (expected a JSON object)");
    return stacks.emplace(file, std::move(j)).first->second;
  };

  std::vector<BatchJob> jobs;
  for (const SceneSpec& scene : m.scenes) {
    auto sh = scene_hashes.find(scene.file);
    if (sh == scene_hashes.end()) sh = scene_hashes.emplace(scene.file, scene_hash(scene.file, &scene_files[scene.file])).first;
    // --stack: each file's content, as the materials' stacks are hashed (its name does not count).
    json stacks_desc = json::array();
    for (const StackAssignment& a : scene.stacks) stacks_desc.push_back({{"material", a.material}, {"stack_hash", file_hash(a.path)}});
    std::vector<JobInput> scene_inputs = {{"the scene", scene.file}};
    for (const std::string& f : scene_files[scene.file]) scene_inputs.push_back({"a file of the scene '" + scene.file + "'", f});
    for (const StackAssignment& a : scene.stacks) scene_inputs.push_back({"a stack file", a.path});
    for (std::size_t vi = 0; vi < m.variants.size(); ++vi) {
      const VariantSpec& variant = m.variants[vi];
      // The stacks of this scene under this variant, by glTF material name.
      std::map<std::string, MaterialBinding> bindings;
      // A material the scene's stack assignments cover is rendered from the assigned file (as
      // --stack wins over --materials), not from the map.
      for (const auto& [name, file] : scene.materials)
        if (!scene.stack_assigned(name)) bindings[name] = {name, stack_json(file), false};
      for (std::size_t oi = 0; oi < variant.overrides.size(); ++oi) {
        const MaterialOverride& ov = variant.overrides[oi];
        const std::string file = ov.stack.empty() ? scene.materials.at(ov.material) : ov.stack;
        MaterialBinding b{ov.material, stack_json(file), true};
        apply_stack_override(b.stack, ov,
                             m.path + ": variants[" + std::to_string(vi) + "].overrides[" + std::to_string(oi) + "] (" + file + ")");
        bindings[ov.material] = std::move(b);
      }
      json materials_desc = json::object();
      std::vector<MaterialBinding> binding_list;
      std::vector<JobInput> variant_inputs = scene_inputs;
      for (const auto& [name, file] : scene.materials)
        if (bindings.count(name)) variant_inputs.push_back({"the stack file of material '" + name + "'", file});
      for (const MaterialOverride& ov : variant.overrides)
        if (!ov.stack.empty()) variant_inputs.push_back({"the stack file of material '" + ov.material + "'", ov.stack});
      for (auto& [name, b] : bindings) {
        materials_desc[name] = content_hash(b.stack.dump());
        binding_list.push_back(b);
      }
      for (const LightingSpec& lighting : m.lighting) {
        json env_desc = lighting.env;
        if (lighting.env_is_file) {
          auto eh = env_hashes.find(lighting.env);
          if (eh == env_hashes.end()) eh = env_hashes.emplace(lighting.env, file_hash(lighting.env)).first;
          env_desc = json{{"file_hash", eh->second}};
        }
        for (const ModeSpec& mode : m.modes) {
          for (int spp : m.spp) {
            BatchJob job;
            job.index = jobs.size();
            job.scene = scene.name;
            job.variant = variant.name;
            job.lighting = lighting.name;
            job.mode = mode.name;
            job.subsurface = mode.subsurface;
            job.spp = spp;
            job.id = scene.name + "__" + variant.name + "__" + lighting.name + "__" + mode.name + "__spp" + std::to_string(spp);
            job.scene_file = scene.file;
            job.materials = binding_list;
            job.stacks = scene.stacks;
            job.spectral = scene.spectral;
            job.inputs = variant_inputs;
            if (lighting.env_is_file) job.inputs.push_back({"the environment", lighting.env});
            job.env = lighting.env;
            job.camera = lighting.camera;
            // Everything that changes the pixels, and nothing else (not names, paths or the
            // thread count: rendering is deterministic for any thread count). "mode" is the
            // --subsurface argument, not the mode's name; the tolerance only exists for auto, so
            // the hashes of fixed-mode jobs are those of manifests written before auto existed.
            job.description = json{{"lamina_version", lamina_version()},
                                   {"scene_hash", sh->second},
                                   {"materials", materials_desc},
                                   {"env", env_desc},
                                   {"camera", lighting.camera},
                                   {"mode", mode.subsurface.name()},
                                   {"spp", spp},
                                   {"seed", m.settings.seed},
                                   {"width", m.settings.width},
                                   {"height", m.settings.height},
                                   {"max_depth", m.settings.max_depth}};
            if (mode.subsurface.automatic) job.description["tolerance"] = mode.subsurface.tolerance;
            // Only with --stack, so that the hashes of other jobs are those they always were.
            if (!stacks_desc.empty()) job.description["stack"] = stacks_desc;
            // Likewise only in the spectral mode.
            if (scene.spectral) job.description[spectral_option_key()] = true;
            job.hash = content_hash(job.description.dump());
            jobs.push_back(std::move(job));
          }
        }
      }
    }
  }
  return jobs;
}

std::vector<ComparisonPair> resolve_comparisons(const Manifest& m, const std::vector<BatchJob>& jobs) {
  auto key = [](const std::string& scene, const std::string& variant, const std::string& lighting, const std::string& mode, int spp) {
    return scene + "\n" + variant + "\n" + lighting + "\n" + mode + "\n" + std::to_string(spp);
  };
  std::map<std::string, std::size_t> by_axes;
  for (const BatchJob& j : jobs) by_axes[key(j.scene, j.variant, j.lighting, j.mode, j.spp)] = j.index;
  auto matches = [](const JobSelector& s, const BatchJob& j) {
    return (s.scene.empty() || s.scene == j.scene) && (s.variant.empty() || s.variant == j.variant) &&
           (s.lighting.empty() || s.lighting == j.lighting) && (s.mode.empty() || s.mode == j.mode) && (s.spp == 0 || s.spp == j.spp);
  };
  std::vector<ComparisonPair> pairs;
  for (std::size_t ci = 0; ci < m.comparisons.size(); ++ci) {
    const ComparisonSpec& c = m.comparisons[ci];
    const JobSelector& r = c.reference;
    std::size_t count = 0;
    for (const BatchJob& t : jobs) {
      if (!matches(c.test, t)) continue;
      const std::string k = key(r.scene.empty() ? t.scene : r.scene, r.variant.empty() ? t.variant : r.variant,
                                r.lighting.empty() ? t.lighting : r.lighting, r.mode.empty() ? t.mode : r.mode, r.spp == 0 ? t.spp : r.spp);
      const auto it = by_axes.find(k);
      if (it == by_axes.end())
        throw ManifestError(m.path + ": comparisons[" + std::to_string(ci) + "]: no reference job for test '" + t.id + "'");
      if (it->second == t.index) continue;
      pairs.push_back({c.name, it->second, t.index, c.name + "__" + t.id});
      ++count;
    }
    if (count == 0) throw ManifestError(m.path + ": comparisons[" + std::to_string(ci) + "]: '" + c.name + "' matches no pair of jobs");
  }
  return pairs;
}

bool in_shard(std::size_t job_index, int shard, int shard_count) {
  return shard_count <= 1 || job_index % static_cast<std::size_t>(shard_count) == static_cast<std::size_t>(shard);
}

std::pair<int, int> parse_shard(const std::string& text) {
  const std::size_t slash = text.find('/');
  auto number = [&](const std::string& s) {
    if (s.empty() || s.size() > 6 || s.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
    return std::stoi(s);
  };
  if (slash == std::string::npos) throw std::invalid_argument("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
  const int i = number(text.substr(0, slash)), n = number(text.substr(slash + 1));
  if (n < 1 || i >= n) throw std::invalid_argument("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
  return {i, n};
}

}  // namespace lamina
