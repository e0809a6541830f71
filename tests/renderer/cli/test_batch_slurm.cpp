// scripts/batch_slurm.sh on a private single-node Slurm cluster (scripts/lib/local_slurm.sh: its
// own munged, slurmctld and slurmd on free ports, all in a temporary directory) gives the same
// files as a local `lamina batch` (tests/renderer/cli/batch_cluster.h says what "the same" means), apart
// from the Slurm logs in OUT/slurm/. Three array tasks on a 2-CPU node, one thread each, then the
// finalize job; the local run uses all cores in one process. A second test makes one shard fail
// and checks that `--wait` reports it, exits 1 and that the finalize job is cancelled.
//
// Needs Debian's slurm-wlm and munge (scripts/setup.sh installs them) and root. Without them the
// tests fail, unless LAMINA_SKIP_SLURM=1 is set, which skips them with a message. Each test stops
// its cluster when it ends, also on failure; if the test process dies the cluster's watchdog
// (--owner) stops it within a second.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/renderer/cli/batch_cluster.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

const std::string kScripts = std::string(LAMINA_SOURCE_DIR) + "/scripts";
// A run that hangs (e.g. a finalize job left pending for ever) fails the test instead of blocking
// ctest: the runs take seconds.
const std::string kWaitLimit = "timeout 120 ";

// Why Slurm cannot run here, or "" if it can.
std::string slurm_missing() {
  for (const char* exe : {"sbatch", "scontrol", "slurmctld", "slurmd", "munged"})
    if (test::run_shell(std::string("PATH=\"$PATH:/usr/sbin\" command -v ") + exe + " >/dev/null 2>&1") != 0)
      return std::string(exe) + " is not installed (Debian packages slurm-wlm and munge; scripts/setup.sh installs them)";
  if (::geteuid() != 0) return "the private cluster's daemons need root (scripts/lib/local_slurm.sh)";
  return "";
}

// A private cluster for the lifetime of the object; `env` is a shell file exporting SLURM_CONF.
struct LocalSlurm {
  std::string env, dir, error;
  explicit LocalSlurm(const fs::path& work) {
    env = (work / "cluster.env").string();
    const std::string log = (work / "cluster.log").string();
    const int rc = test::run_shell(kScripts + "/lib/local_slurm.sh start --owner " + std::to_string(::getpid()) + " >'" + env +
                                   "' 2>'" + log + "'");
    std::ifstream in(env);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("export LAMINA_SLURM_DIR=", 0) == 0) dir = line.substr(24);
    if (rc != 0 || dir.empty()) error = "scripts/lib/local_slurm.sh start failed:\n" + test::slurp(log);
  }
  ~LocalSlurm() {
    if (!dir.empty()) test::run_shell(kScripts + "/lib/local_slurm.sh stop " + dir);
  }
  // `cmd` run by sh with the cluster's environment.
  int run(const std::string& cmd) const { return test::run_shell(". '" + env + "' && " + cmd); }
};

#define REQUIRE_SLURM()                                                                       \
  if (const std::string why = slurm_missing(); !why.empty()) {                                \
    if (const char* skip = std::getenv("LAMINA_SKIP_SLURM"); skip && std::string(skip) == "1") \
      GTEST_SKIP() << "LAMINA_SKIP_SLURM=1 and " << why;                                      \
    FAIL() << why << "; set LAMINA_SKIP_SLURM=1 to skip this test";                           \
  }

TEST(BatchSlurm, SameFilesAsALocalRun) {
  REQUIRE_SLURM();
  TempDir dir("batch-slurm");
  const std::string manifest = test::write_tiny_batch(dir.path);
  const std::string out = dir / "out";

  // The cluster first: its scheduler starts 3 s after slurmctld, the local run meanwhile.
  const LocalSlurm slurm(dir.path);
  ASSERT_EQ(slurm.error, "");

  // Local run, moved aside; then the Slurm run into the same path (so the command lines recorded
  // in the EXR headers are the same).
  ASSERT_EQ(test::run_shell(std::string(LAMINA_EXE) + " batch " + manifest + " --out " + out + " >" + (dir / "local.log") + " 2>&1"), 0)
      << test::slurp(dir / "local.log");
  fs::rename(out, dir / "local");
  ASSERT_EQ(slurm.run("LAMINA=" + std::string(LAMINA_EXE) + " " + kWaitLimit + kScripts + "/batch_slurm.sh --wait " + manifest + " " + out +
                      " 3 >" + (dir / "slurm.log") + " 2>&1"),
            0)
      << test::slurp(dir / "slurm.log") << test::slurp(out + "/slurm/finalize.log");

  EXPECT_EQ(test::expect_same_batch_outputs(dir / "local", out, {"slurm"}), 8u + 4u);  // the images and the differences
  // Each task rendered with the one CPU Slurm gave it (SLURM_CPUS_ON_NODE), not every core.
  for (const char* log : {"shard-0.log", "shard-1.log", "shard-2.log", "finalize.log"})
    EXPECT_TRUE(fs::exists(out + "/slurm/" + log)) << log;
  std::string command;
  for (const auto& [key, value] : read_metadata(out + "/jobs/quad__base__grey__lambert__spp4.exr"))
    if (key == "lamina:command") command = value;
  EXPECT_NE(command.find(" --threads 1 "), std::string::npos) << command;
}

TEST(BatchSlurm, AFailedShardFailsTheWaitAndCancelsFinalize) {
  REQUIRE_SLURM();
  TempDir dir("batch-slurm-fail");
  const std::string manifest = test::write_tiny_batch(dir.path);
  const std::string out = dir / "out";
  // A lamina that fails as shard 1 of 2 and is the real one otherwise.
  const std::string wrapper = dir / "lamina-fails-shard-1";
  std::ofstream(wrapper) << "#!/bin/sh\ncase \" $* \" in *' --shard 1/2 '*) echo 'shard 1 fails on purpose' >&2; exit 3 ;; esac\nexec "
                         << LAMINA_EXE << " \"$@\"\n";
  fs::permissions(wrapper, fs::perms::owner_all);

  const LocalSlurm slurm(dir.path);
  ASSERT_EQ(slurm.error, "");
  EXPECT_EQ(slurm.run("LAMINA=" + wrapper + " " + kWaitLimit + kScripts + "/batch_slurm.sh --wait " + manifest + " " + out + " 2 >" +
                      (dir / "slurm.log") + " 2>&1"),
            1);
  const std::string log = test::slurp(dir / "slurm.log");
  EXPECT_NE(log.find("shard 1 (job "), std::string::npos) << log;
  EXPECT_NE(log.find("FAILED, exit code 3:0"), std::string::npos) << log;
  EXPECT_NE(log.find("finalize (job "), std::string::npos) << log;
  EXPECT_EQ(log.find("shard 0 (job "), std::string::npos) << log;  // shard 0 succeeded
  EXPECT_NE(test::slurp(out + "/slurm/shard-1.log").find("shard 1 fails on purpose"), std::string::npos);
  EXPECT_FALSE(fs::exists(out + "/summary.csv"));  // finalize never ran
}

}  // namespace
}  // namespace lamina
