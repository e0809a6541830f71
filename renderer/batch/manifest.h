// A batch manifest's schema (docs/batch.md): the structs a manifest is read into, and reading
// and validating one. Expanding it into jobs is jobs.h; batch_manifest.h includes both.
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/image/tone_map.h"
#include "renderer/layered/stack_assignment.h"
#include "renderer/layered/subsurface_mode.h"

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
  // `lamina render --stack` (renderer/layered/stack_assignment.h) for this scene's jobs: the
  // settings' assignments, then the scene's own, files absolute. They win over `materials`.
  std::vector<StackAssignment> stacks;
  // `lamina render --spectral` (renderer/render/spectral_option.h) for this scene's jobs: the
  // scene's own "spectral", else the settings'.
  bool spectral = false;
  // Whether `stacks` covers a glTF material (named, or FILE for all).
  bool stack_assigned(const std::string& material) const {
    for (const StackAssignment& a : stacks)
      if (a.all() || a.material == material) return true;
    return false;
  }
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
  SubsurfaceChoice subsurface;  // auto's tolerance in (0, 1]
};

struct ContactSheetSpec {
  int columns = 4;
  int thumbnail_width = 160;
  double diff_range = 0.25;  // relative difference shown at full red/blue in diff thumbnails
  double diff_smooth = 2.0;  // Gaussian sigma in pixels the difference pictures smooth both images by (0: none)
  ToneMap tone_map;          // of the jobs' PNGs and thumbnails (the differences are false colour)
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

}  // namespace lamina
