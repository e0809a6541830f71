// A batch manifest's render jobs (docs/batch.md): the expansion of a manifest into a
// deterministic list of jobs with stable ids and content hashes, the stack overrides of its
// variants, the comparisons between jobs, and shards of the list.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/batch/manifest.h"
#include "renderer/util/content_hash.h"

namespace lamina {

// The layer stack one job renders a glTF material with (the stack file after the variant's
// settings).
struct MaterialBinding {
  std::string material;       // glTF material name
  nlohmann::json stack;       // the stack JSON to write
  bool overridden = false;    // a variant changed it
};

// A file a job reads: how a message names it, and its path.
struct JobInput {
  std::string what, path;
};

struct BatchJob {
  std::size_t index = 0;  // position in the expansion order
  std::string id;         // scene__variant__lighting__mode__sppN: the output file's stem
  std::string scene, variant, lighting, mode;  // mode: the ModeSpec's name
  SubsurfaceChoice subsurface;  // the --subsurface argument (and --tolerance with auto)
  int spp = 0;
  std::string scene_file;
  std::vector<MaterialBinding> materials;  // sorted by material name; none a stack assignment covers
  std::vector<StackAssignment> stacks;     // --stack: the scene's assignments (SceneSpec::stacks)
  bool spectral = false;                   // --spectral (SceneSpec::spectral)
  // Every file the job reads, which no output of the batch may be: the scene, the buffers and
  // images it names, the stack files and the environment map.
  std::vector<JobInput> inputs;
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
// content_hash over a glTF file and the external files it references (buffers, images); their
// paths are appended to *files if given.
std::string scene_hash(const std::string& path, std::vector<std::string>* files = nullptr);

}  // namespace lamina
