// scripts/batch_ray.py on a local Ray cluster gives the same files as a local `lamina batch`:
// the same set of files; EXRs with bit-identical pixels and identical headers except the write
// time, the render time and the thread count; identical PNGs (previews, diffs, contact sheet), comparisons.csv, jobs.json and
// material files; summary.csv identical except the timing columns. The local run uses all
// cores in one process, the Ray run one thread per shard in three shards, so this also checks
// that the images do not depend on threads or sharding.
//
// Needs the Python package `ray` (scripts/test.sh installs the pinned version). Without it the
// test fails, unless LAMINA_SKIP_RAY=1 is set, which skips it with a message.
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/image_io.h"
#include "tests/renderer/batch_fixture.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::TempDir;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int run(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::set<std::string> files_under(const fs::path& root) {
  std::set<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) files.insert(fs::relative(e.path(), root).string());
  return files;
}

// The CSV without the columns named in `drop`.
std::string csv_without(const std::string& text, const std::set<std::string>& drop) {
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
Metadata reproducible(Metadata m) {
  m.erase(std::remove_if(m.begin(), m.end(), [](const auto& kv) { return kv.first == "DateTime" || kv.first == "lamina:seconds"; }),
          m.end());
  for (auto& [key, value] : m) {
    const std::size_t at = value.find(" --threads ");
    if (key == "lamina:command" && at != std::string::npos) value.erase(at, value.find(' ', at + 11) - at);
  }
  return m;
}

TEST(BatchRay, SameFilesAsALocalRun) {
  if (run("python3 -c 'import ray' >/dev/null 2>&1") != 0) {
    if (const char* skip = std::getenv("LAMINA_SKIP_RAY"); skip && std::string(skip) == "1")
      GTEST_SKIP() << "LAMINA_SKIP_RAY=1 and the Python package ray is not installed";
    FAIL() << "the Python package ray is not installed: run scripts/test.sh (it installs it), pip install ray, or set "
              "LAMINA_SKIP_RAY=1 to skip this test";
  }
  TempDir dir("batch-ray");
  testing::write_batch_quad(dir / "quad.gltf");
  const json manifest = {{"lamina_batch", 1},
                         {"settings", {{"width", 24}, {"height", 18}, {"seed", 5}, {"max_depth", 4}}},
                         {"scenes", {{{"name", "quad"}, {"file", "quad.gltf"}}}},
                         {"lighting", {{{"name", "grey"}, {"env", 1.0}}, {{"name", "blue"}, {"env", {0.2, 0.3, 1.0}}}}},
                         {"modes", {"random-walk", "lambert"}},
                         {"spp", {4, 16}},
                         {"comparisons", {{{"name", "noise"}, {"reference", {{"spp", 16}}}, {"test", json::object()}}}},
                         {"contact_sheet", {{"thumbnail_width", 48}}}};
  testing::write_json(dir / "m.json", manifest);
  const std::string out = dir / "out";

  // Local run, moved aside; then the Ray run into the same path (so the command lines recorded
  // in the EXR headers are the same).
  ASSERT_EQ(run(std::string(LAMINA_EXE) + " batch " + (dir / "m.json") + " --out " + out + " >" + (dir / "local.log") + " 2>&1"), 0)
      << slurp(dir / "local.log");
  fs::rename(out, dir / "local");
  const std::string driver = std::string(LAMINA_SOURCE_DIR) + "/scripts/batch_ray.py";
  ASSERT_EQ(run("python3 " + driver + " " + (dir / "m.json") + " --out " + out + " --shards 3 --num-cpus 2 --lamina " + LAMINA_EXE +
                " >" + (dir / "ray.log") + " 2>&1"),
            0)
      << slurp(dir / "ray.log");

  const std::set<std::string> local = files_under(dir / "local");
  ASSERT_EQ(files_under(out), local);
  std::size_t exrs = 0;
  for (const std::string& f : local) {
    SCOPED_TRACE(f);
    const std::string a = dir / ("local/" + f), b = (fs::path(out) / f).string();
    if (fs::path(f).extension() == ".exr") {
      ++exrs;
      EXPECT_EQ(read_image(a).rgb, read_image(b).rgb);  // float ==: bit-identical for finite values
      Metadata ma = read_metadata(a), mb = read_metadata(b);
      EXPECT_EQ(reproducible(ma), reproducible(mb));
    } else if (f == "summary.csv") {
      EXPECT_EQ(csv_without(slurp(a), {"seconds", "rays_per_second"}), csv_without(slurp(b), {"seconds", "rays_per_second"}));
    } else {
      EXPECT_EQ(slurp(a), slurp(b));
    }
  }
  EXPECT_EQ(exrs, 8u + 4u);  // the images and the differences
}

}  // namespace
}  // namespace lamina
