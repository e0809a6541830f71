// scripts/batch_ray.py on a local Ray cluster gives the same files as a local `lamina batch`
// (tests/renderer/cli/batch_cluster.h says what "the same" means). The local run uses all cores in one
// process, the Ray run one thread per shard in three shards, so this also checks that the images
// do not depend on threads or sharding.
//
// Needs the Python package `ray` (scripts/test.sh installs the pinned version). Without it the
// test fails, unless LAMINA_SKIP_RAY=1 is set, which skips it with a message.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "tests/renderer/cli/batch_cluster.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

TEST(BatchRay, SameFilesAsALocalRun) {
  if (test::run_shell("python3 -c 'import ray' >/dev/null 2>&1") != 0) {
    if (const char* skip = std::getenv("LAMINA_SKIP_RAY"); skip && std::string(skip) == "1")
      GTEST_SKIP() << "LAMINA_SKIP_RAY=1 and the Python package ray is not installed";
    FAIL() << "the Python package ray is not installed: run scripts/test.sh (it installs it), pip install ray, or set "
              "LAMINA_SKIP_RAY=1 to skip this test";
  }
  TempDir dir("batch-ray");
  const std::string manifest = test::write_tiny_batch(dir.path);
  const std::string out = dir / "out";

  // Local run, moved aside; then the Ray run into the same path (so the command lines recorded
  // in the EXR headers are the same).
  ASSERT_EQ(test::run_shell(std::string(LAMINA_EXE) + " batch " + manifest + " --out " + out + " >" + (dir / "local.log") + " 2>&1"), 0)
      << test::slurp(dir / "local.log");
  fs::rename(out, dir / "local");
  const std::string driver = std::string(LAMINA_SOURCE_DIR) + "/scripts/batch_ray.py";
  ASSERT_EQ(test::run_shell("python3 " + driver + " " + manifest + " --out " + out + " --shards 3 --num-cpus 2 --lamina " + LAMINA_EXE +
                " >" + (dir / "ray.log") + " 2>&1"),
            0)
      << test::slurp(dir / "ray.log");

  EXPECT_EQ(test::expect_same_batch_outputs(dir / "local", out), 8u + 4u);  // the images and the differences
}

}  // namespace
}  // namespace lamina
