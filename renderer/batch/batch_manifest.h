// Batch manifests (docs/batch.md): a JSON file listing scenes x material variants x lighting
// set-ups x modes x samples per pixel, and the comparisons to make between the resulting
// images. This file parses and validates a manifest and expands it into a deterministic list
// of render jobs, each with a stable id and a hash of everything that affects its image.
// Nothing here renders or writes files: renderer/cli/batch.cpp does.
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/util/content_hash.h"

namespace lamina {

// Thrown with one line: "<manifest file>: <JSON path>: <problem>".
struct ManifestError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One change to a layer stack: the value at a path such as "layers[1].components[0].fraction".
struct StackSetting {
  std::string path;
  nlohmann::json value;
};

// A variant's change to one glTF material: which stack (default: the scene's for that
// material), which values to set, and whether the untouched component fractions of a layer
// whose fractions were set are rescaled so the layer's fractions sum to 1 again.
struct MaterialOverride {
  std::string material;  // glTF material name
  std::string stack;     // absolute path, or empty: the scene's mapping
  std::vector<StackSetting> set;
  bool renormalise = false;
};

struct VariantSpec {
  std::string name;
  std::vector<MaterialOverride> overrides;
};

struct SceneSpec {
  std::string name;
  std::string file;                           // absolute path of the .gltf/.glb
  std::map<std::string, std::string> materials;  // glTF material name -> stack file (absolute)
};

// Extra arguments of `lamina render` that set the lighting: the environment and the camera.
struct LightingSpec {
  std::string name;
  std::string env;       // the --env argument ("" for black): a number, R,G,B or a file path
  bool env_is_file = false;
  std::string camera;    // --camera ("" for the render's default)
};

// A partial assignment of the job axes; an empty field matches anything.
struct JobSelector {
  std::string scene, variant, lighting, mode;
  int spp = 0;  // 0: any
};

struct ComparisonSpec {
  std::string name;
  JobSelector reference, test;
};

struct RenderSettingsSpec {
  int width = 320;
  int height = 240;
  std::uint64_t seed = 0;
  int max_depth = 16;
};

// How a job shades its layered materials: a `lamina render --subsurface` mode, or "auto" with a
// tolerance (--subsurface auto --tolerance E: per material, the cheapest mode whose predicted
// error is within E; renderer/layered/subsurface_auto.h). `name` is what job ids, comparison selectors
// and the summary use: the mode itself for a plain string in the manifest, or the object's
// "name" (default "auto-<tolerance>" for auto, the mode for a fixed mode).
struct ModeSpec {
  std::string name;
  std::string subsurface;  // random-walk, first-order, table, lambert or auto
  double tolerance = 0.0;  // auto only: in (0, 1]; 0 for the fixed modes
};

struct ContactSheetSpec {
  int columns = 4;
  int thumbnail_width = 160;
  double diff_range = 0.25;  // relative difference shown at full red/blue in diff thumbnails
};

struct Manifest {
  std::string path;  // as given
  std::string directory;  // absolute; relative paths in the manifest are resolved against it
  RenderSettingsSpec settings;
  std::vector<SceneSpec> scenes;
  std::vector<VariantSpec> variants;
  std::vector<LightingSpec> lighting;
  std::vector<ModeSpec> modes;
  std::vector<int> spp;
  std::vector<ComparisonSpec> comparisons;
  ContactSheetSpec contact_sheet;
};

// Reads and validates a manifest: unknown keys, bad types and values, duplicate or unsafe
// names, missing files (scenes, stacks, environment maps), glTF materials and cameras that
// the scene does not have, and stack settings that do not apply are all ManifestErrors.
Manifest load_manifest(const std::string& path);
// The same from JSON text (`path` names it in errors; `directory` resolves relative paths).
Manifest parse_manifest(const nlohmann::json& json, const std::string& path, const std::string& directory);

// The layer stack one job renders a glTF material with (the stack file after the variant's
// settings).
struct MaterialBinding {
  std::string material;       // glTF material name
  nlohmann::json stack;       // the stack JSON to write
  bool overridden = false;    // a variant changed it
};

struct BatchJob {
  std::size_t index = 0;  // position in the expansion order
  std::string id;         // scene__variant__lighting__mode__sppN: the output file's stem
  std::string scene, variant, lighting, mode;  // mode: the ModeSpec's name
  std::string subsurface;  // the --subsurface argument
  double tolerance = 0.0;  // the --tolerance argument when subsurface is "auto"
  int spp = 0;
  std::string scene_file;
  std::vector<MaterialBinding> materials;  // sorted by material name
  std::string env;  // --env argument ("" for none)
  std::string camera;
  nlohmann::json description;  // everything that affects the image, canonical
  std::string hash;            // content_hash of description.dump()
};

// The product scenes x variants x lighting x modes x spp in that nesting order (the scene
// varies slowest), so indices are a pure function of the manifest. Reads the scene, stack and
// environment files to hash their contents. Throws ManifestError when an override does not
// apply to a stack.
std::vector<BatchJob> expand_jobs(const Manifest& manifest);

// A resolved comparison: indices into the job list.
struct ComparisonPair {
  std::string name;  // the comparison's name
  std::size_t reference = 0, test = 0;
  std::string id;  // name__<test job id>: the difference image's stem
};
// For each comparison, every job matching `test` is paired with the job that has the same
// axes except those `reference` names. A test job that is its own reference is left out; a
// missing reference job is a ManifestError. Order: comparisons in manifest order, then tests in
// job order.
std::vector<ComparisonPair> resolve_comparisons(const Manifest& manifest, const std::vector<BatchJob>& jobs);

// The variant settings applied to a stack JSON (throws ManifestError naming `where`, e.g.
// "m.json: variants[1].overrides[0]", when a path does not exist or renormalising fails).
void apply_stack_override(nlohmann::json& stack, const MaterialOverride& override_spec, const std::string& where);

// --shard i/n: job k belongs to shard k mod n. Deterministic, balanced to within one job, and
// every job is in exactly one shard.
bool in_shard(std::size_t job_index, int shard, int shard_count);
// Parses "i/n" (0 <= i < n); throws std::invalid_argument with a one-line message.
std::pair<int, int> parse_shard(const std::string& text);

// content_hash of a file's bytes; throws ManifestError naming the file if it cannot be read.
std::string file_hash(const std::string& path);
// content_hash over a glTF file and the external files it references (buffers, images).
std::string scene_hash(const std::string& path);

}  // namespace lamina
