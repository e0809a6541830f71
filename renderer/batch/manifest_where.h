// Internal to renderer/batch/ (manifest.cpp, jobs.cpp): where a value sits in a manifest, for
// error messages, and the stack paths of overrides, which both the manifest's validation and
// the jobs' stack overrides read.
#pragma once

#include <string>
#include <vector>

#include "materials/stack/stack_parameters.h"
#include "renderer/batch/manifest.h"

namespace lamina {
namespace batch_detail {

// Where a value sits in the manifest, for error messages: "m.json: variants[1].name".
struct Where {
  std::string file;
  std::string path;
  Where key(const std::string& k) const { return {file, path.empty() ? k : path + "." + k}; }
  Where at(std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
  [[noreturn]] void fail(const std::string& message) const {
    throw ManifestError(file + ": " + (path.empty() ? "" : path + ": ") + message);
  }
};

// A "set" path such as "layers[1].components[0].fraction" split into keys and indices
// (materials/stack/stack_parameters.h split_stack_path); a ManifestError at `where` if it is malformed.
std::vector<StackPathStep> stack_path_steps(const std::string& path, const Where& where);

}  // namespace batch_detail
}  // namespace lamina
