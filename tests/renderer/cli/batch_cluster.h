// What the cluster batch-driver tests (test_batch_ray.cpp, test_batch_slurm.cpp) share: the tiny
// manifest they render, and the check that a cluster run wrote the same files as a local
// `lamina batch`: the same set of files; EXRs with bit-identical pixels and identical headers
// except the write time, the render time and the thread count; identical PNGs (previews, diffs,
// contact sheet), comparisons.csv, jobs.json and material files; summary.csv identical except
// the timing columns.
#pragma once

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "renderer/image/image_io.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/batch_fixture.h"

namespace lamina::test {

// The exit status of a shell command (128 if a signal ended it).
inline int run_shell(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

// Writes dir/quad.gltf and dir/m.json, a batch of 8 small jobs (one quad, two lightings, two
// modes, 4 and 16 spp) with 4 differences (each 4 spp job against its 16 spp job) and a contact
// sheet; returns the manifest's path.
inline std::string write_tiny_batch(const std::filesystem::path& dir) {
  testing::write_batch_quad((dir / "quad.gltf").string());
  const nlohmann::json manifest = {
      {"lamina_batch", 1},
      {"settings", {{"width", 24}, {"height", 18}, {"seed", 5}, {"max_depth", 4}}},
      {"scenes", {{{"name", "quad"}, {"file", "quad.gltf"}}}},
      {"lighting", {{{"name", "grey"}, {"env", 1.0}}, {{"name", "blue"}, {"env", {0.2, 0.3, 1.0}}}}},
      {"modes", {"random-walk", "lambert"}},
      {"spp", {4, 16}},
      {"comparisons", {{{"name", "noise"}, {"reference", {{"spp", 16}}}, {"test", nlohmann::json::object()}}}},
      {"contact_sheet", {{"thumbnail_width", 48}}}};
  const std::string path = (dir / "m.json").string();
  testing::write_json(path, manifest);
  return path;
}

// Every regular file under root, as paths relative to it, except those under the directories
// named in `skip` (relative to root).
inline std::set<std::string> files_under(const std::filesystem::path& root, const std::set<std::string>& skip = {}) {
  namespace fs = std::filesystem;
  std::set<std::string> files;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it) {
    const std::string rel = fs::relative(it->path(), root).string();
    if (it->is_directory() && skip.count(rel)) {
      it.disable_recursion_pending();
    } else if (it->is_regular_file()) {
      files.insert(rel);
    }
  }
  return files;
}

// The CSV without the columns named in `drop`.
inline std::string csv_without(const std::string& text, const std::set<std::string>& drop) {
  std::istringstream in(text);
  std::string line, out;
  std::vector<bool> keep;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::string f;
    std::istringstream ls(line);
    while (std::getline(ls, f, ',')) fields.push_back(f);
    if (!line.empty() && line.back() == ',') fields.push_back("");
    if (keep.empty())
      for (const std::string& name : fields) keep.push_back(!drop.count(name));
    for (std::size_t i = 0; i < fields.size() && i < keep.size(); ++i)
      if (keep[i]) out += fields[i] + ",";
    out += "\n";
  }
  return out;
}

// The header without what records when and how fast a file was made: the write time
// (OpenImageIO's DateTime), the render time, and the thread count in the command line.
inline Metadata reproducible(Metadata m) {
  m.erase(std::remove_if(m.begin(), m.end(), [](const auto& kv) { return kv.first == "DateTime" || kv.first == "lamina:seconds"; }),
          m.end());
  for (auto& [key, value] : m) {
    const std::size_t at = value.find(" --threads ");
    if (key == "lamina:command" && at != std::string::npos) value.erase(at, value.find(' ', at + 11) - at);
  }
  return m;
}

// Checks (with gtest EXPECTs) that `cluster` holds the same outputs as `local` (see the top of
// this file), ignoring the directories `skip` of `cluster` (e.g. the driver's own logs). The runs
// must have written to the same --out path (move the first aside before the second), since the
// command line in each EXR header names it. Returns the number of EXRs compared.
inline std::size_t expect_same_batch_outputs(const std::filesystem::path& local, const std::filesystem::path& cluster,
                                             const std::set<std::string>& skip = {}) {
  const std::set<std::string> files = files_under(local);
  EXPECT_EQ(files_under(cluster, skip), files);
  std::size_t exrs = 0;
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    const std::string a = (local / f).string(), b = (cluster / f).string();
    if (!std::filesystem::exists(b)) continue;  // reported by the set comparison above
    if (std::filesystem::path(f).extension() == ".exr") {
      ++exrs;
      EXPECT_EQ(read_image(a).rgb, read_image(b).rgb);  // float ==: bit-identical for finite values
      EXPECT_EQ(reproducible(read_metadata(a)), reproducible(read_metadata(b)));
    } else if (f == "summary.csv") {
      EXPECT_EQ(csv_without(slurp(a), {"seconds", "rays_per_second"}), csv_without(slurp(b), {"seconds", "rays_per_second"}));
    } else {
      EXPECT_EQ(slurp(a), slurp(b));
    }
  }
  return exrs;
}

}  // namespace lamina::test
