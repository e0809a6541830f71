// `lamina compare` end to end: outputs, metrics, colours, exit codes, errors.
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/image_files.h"
#include "renderer/cli/outputs.h"
#include "renderer/image/image_io.h"
#include "tests/renderer/cli/cli_runner.h"

namespace fs = std::filesystem;
namespace lamina {
namespace {

// A fresh directory per test, so tests may run in parallel (ctest -j) without sharing files.
fs::path dir() {
  static fs::path d;
  const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  if (d.empty() || d.filename() != name) {
    d = fs::path(::testing::TempDir()) / "lamina_cli_compare" / name;
    fs::remove_all(d);
    fs::create_directories(d);
  }
  return d;
}

using CommandResult = test::CliResult;
using test::slurp;

// `lamina ARGS`, run in this test's directory.
CommandResult lamina(const std::string& args) { return test::run_lamina(dir(), args); }

std::string grey_exr(const std::string& name, int w, int h, std::initializer_list<float> values) {
  Image image(w, h);
  std::size_t i = 0;
  for (float v : values) {
    image.rgb[3 * i] = image.rgb[3 * i + 1] = image.rgb[3 * i + 2] = v;
    ++i;
  }
  const std::string path = (dir() / name).string();
  write_exr(path, image);
  return path;
}

TEST(CliCompare, HelpExitsZero) {
  const CommandResult r = lamina("compare --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--fail-above"), std::string::npos);
}

TEST(CliCompare, MetricsDiffAndSign) {
  // REF = 1; TEST = 1.5 (left column) and 0.5 (right column): relative +0.5 and -0.5, so the
  // mean is 0, the RMS 0.5, MAE 0.5, MSE 0.25.
  const std::string ref = grey_exr("ref.exr", 2, 2, {1, 1, 1, 1});
  const std::string test = grey_exr("test.exr", 2, 2, {1.5f, 0.5f, 1.5f, 0.5f});
  const fs::path exr = dir() / "diff.exr", png = dir() / "diff.png", json = dir() / "m.json";
  const CommandResult r = lamina("compare " + ref + " " + test + " -o " + exr.string() + " --png " + png.string() +
                       " --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("RMS relative difference"), std::string::npos);

  const nlohmann::json m = nlohmann::json::parse(slurp(json));
  EXPECT_NEAR(m["mean_relative"].get<double>(), 0.0, 1e-7);
  EXPECT_NEAR(m["rms_relative"].get<double>(), 0.5, 1e-7);
  EXPECT_NEAR(m["mae"].get<double>(), 0.5, 1e-7);
  EXPECT_NEAR(m["mse"].get<double>(), 0.25, 1e-7);
  EXPECT_NEAR(m["rmse"].get<double>(), 0.5, 1e-7);
  EXPECT_LT(m["ssim"].get<double>(), 1.0);

  const Image diff = read_image(exr.string());
  EXPECT_NEAR(diff.pixel(0, 1)[0], 0.5, 1e-7);
  EXPECT_NEAR(diff.pixel(1, 1)[2], -0.5, 1e-7);

  // With the default range +-50%, +0.5 is full red and -0.5 full blue (the bytes, not decoded).
  int width = 0, height = 0, channels = 0;
  std::vector<unsigned char> bytes = test::read_png8(png.string(), &width, &height, &channels);
  ASSERT_FALSE(bytes.empty());
  const unsigned char* left = &bytes[0];
  const unsigned char* right = &bytes[channels];
  EXPECT_EQ(left[0], 255);
  EXPECT_EQ(left[1], 0);
  EXPECT_EQ(left[2], 0);
  EXPECT_EQ(right[0], 0);
  EXPECT_EQ(right[1], 0);
  EXPECT_EQ(right[2], 255);
  EXPECT_GT(height, 2);  // the legend is below the map

  // --range 1: +0.5 is half way to red: (1, 0.5, 0.5) in display values -> bytes 255, 128, 128.
  const CommandResult r2 = lamina("compare " + ref + " " + test + " --png " + png.string() + " --range 1");
  ASSERT_EQ(r2.exit_code, 0) << r2.err;
  EXPECT_EQ(read_image(png.string()).width, width);
  bytes = test::read_png8(png.string(), &width, &height, &channels);
  ASSERT_FALSE(bytes.empty());
  EXPECT_EQ(bytes[0], 255);
  EXPECT_NEAR(bytes[1], 128, 1);
  EXPECT_NEAR(bytes[2], 128, 1);
}

TEST(CliCompare, GuardNearZeroReference) {
  // mean(REF) = 1 -> floor 0.01; REF 0, TEST 0.005 -> 0.5 instead of infinity.
  const std::string ref = grey_exr("gref.exr", 2, 1, {0.0f, 2.0f});
  const std::string test = grey_exr("gtest.exr", 2, 1, {0.005f, 2.0f});
  const fs::path exr = dir() / "gdiff.exr";
  ASSERT_EQ(lamina("compare " + ref + " " + test + " -o " + exr.string()).exit_code, 0);
  const Image diff = read_image(exr.string());
  EXPECT_NEAR(diff.pixel(0, 0)[1], 0.5, 1e-6);
  EXPECT_EQ(diff.pixel(1, 0)[1], 0.0f);
}

TEST(CliCompare, FailAboveSetsTheExitStatus) {
  const std::string ref = grey_exr("fref.exr", 2, 1, {1, 1});
  const std::string test = grey_exr("ftest.exr", 2, 1, {1.2f, 0.8f});  // RMS relative 0.2
  EXPECT_EQ(lamina("compare " + ref + " " + test + " --fail-above 0.25").exit_code, 0);
  const CommandResult r = lamina("compare " + ref + " " + test + " --fail-above 0.15");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("exceeds"), std::string::npos);
}

TEST(CliCompare, CropRestrictsTheMetrics) {
  const std::string ref = grey_exr("cref.exr", 3, 1, {1, 1, 1});
  const std::string test = grey_exr("ctest.exr", 3, 1, {1, 1, 3});
  const fs::path json = dir() / "c.json";
  ASSERT_EQ(lamina("compare " + ref + " " + test + " --crop 0,0,2,1 --json " + json.string()).exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(slurp(json))["rms_relative"].get<double>(), 0.0);
  EXPECT_EQ(lamina("compare " + ref + " " + test + " --crop 2,0,2,1").exit_code, 2);
  EXPECT_EQ(lamina("compare " + ref + " " + test + " --crop 1,2").exit_code, 2);
}

// The difference of two crops keeps the reference's windows (a derived image stays where its
// input was), moved by --crop; a whole reference gives a whole image.
TEST(CliCompare, TheDifferenceOfCropsKeepsTheirWindows) {
  Image im(4, 3);
  for (float& v : im.rgb) v = 1.0f;
  const std::string ref = (dir() / "crop_ref.exr").string(), test = (dir() / "crop_test.exr").string();
  write_exr(ref, im, {}, {}, DataWindow{5, 2, 20, 10});
  write_exr(test, im, {}, {}, DataWindow{5, 2, 20, 10});
  const std::string diff = (dir() / "d.exr").string();
  ASSERT_EQ(lamina("compare " + ref + " " + test + " -o " + diff).exit_code, 0);
  test::ExrWindows w = test::read_exr_windows(diff);
  EXPECT_EQ(w.x, 5);
  EXPECT_EQ(w.y, 2);
  EXPECT_EQ(w.full_width, 20);
  EXPECT_EQ(w.full_height, 10);
  ASSERT_EQ(lamina("compare " + ref + " " + test + " --crop 1,1,2,2 -o " + diff).exit_code, 0);
  w = test::read_exr_windows(diff);
  EXPECT_EQ(w.x, 6);
  EXPECT_EQ(w.y, 3);
  EXPECT_EQ(w.full_width, 20);
  const std::string whole = grey_exr("whole.exr", 3, 1, {1, 1, 1});
  ASSERT_EQ(lamina("compare " + whole + " " + whole + " --crop 1,0,2,1 -o " + diff).exit_code, 0);
  w = test::read_exr_windows(diff);
  EXPECT_EQ(w.x, 0);
  EXPECT_EQ(w.full_width, 2);  // a whole image: the display window is the data window
}

TEST(CliCompare, BadInputGivesOneLineErrors) {
  const std::string ref = grey_exr("eref.exr", 2, 2, {1, 1, 1, 1});
  const std::string small = grey_exr("esmall.exr", 1, 1, {1});
  const std::string missing = (dir() / "missing.exr").string();

  CommandResult r = lamina("compare " + ref + " " + missing);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;

  r = lamina("compare " + ref + " " + small);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("2x2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1x1"), std::string::npos) << r.err;

  // A one-channel image against an RGB one.
  const std::string one = (dir() / "one.exr").string();
  test::write_exr_channels(one, 2, 2, {"Y"}, {1, 1, 1, 1});
  r = lamina("compare " + ref + " " + one);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("channel"), std::string::npos) << r.err;

  r = lamina("compare " + ref);  // missing TEST
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(lamina("compare " + ref + " " + ref + " --range 0").exit_code, 2);  // range must be > 0
  // An unwritable output names the file.
  const std::string bad_out = (dir() / "no_dir" / "d.exr").string();
  r = lamina("compare " + ref + " " + ref + " -o " + bad_out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(bad_out), std::string::npos) << r.err;
}

// Hostile input: the outputs of a subcommand are written all or none
// (renderer/cli/outputs.h, used by compare and brdf; render_job does the same for render).

// The names in `d` that hold ".tmp-": temporaries left behind.
std::vector<std::string> temporaries(const fs::path& d) {
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(d))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) left.push_back(e.path().string());
  return left;
}

TEST(CliOutputs, AFailedWriteKeepsThePreviousFilesAndLeavesNoTemporaries) {
  const std::string a = (dir() / "a.txt").string(), b = (dir() / "b.txt").string();
  std::ofstream(a) << "old a";
  cli::StagedOutputs outputs;
  outputs.write(a, [](const std::string& tmp) { write_file_atomically(tmp, "new a"); });
  std::string tmp_b;
  try {
    outputs.write(b, [&](const std::string& tmp) {
      tmp_b = tmp;
      throw std::runtime_error("cannot write '" + tmp + "': disk full");
    });
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot write '" + b + "': disk full");  // the output, not its temporary
  }
  EXPECT_EQ(slurp(a), "old a");
  EXPECT_FALSE(fs::exists(b));
  EXPECT_TRUE(temporaries(dir()).empty());
}

TEST(CliOutputs, AFailedRenameRemovesTheOutputsRenamedBeforeIt) {
  const std::string a = (dir() / "a.txt").string(), b = (dir() / "b.txt").string();
  cli::StagedOutputs outputs;
  outputs.write(a, [](const std::string& tmp) { write_file_atomically(tmp, "a"); });
  outputs.write(b, [](const std::string& tmp) { write_file_atomically(tmp, "b"); });
  fs::create_directories(fs::path(b) / "in_the_way");  // rename(2) cannot replace a non-empty directory
  EXPECT_THROW(outputs.commit(), AtomicWriteError);
  EXPECT_FALSE(fs::exists(a)) << "one output of the run without the other";
  EXPECT_TRUE(fs::is_directory(b));
  EXPECT_TRUE(temporaries(dir()).empty());
}

TEST(CliOutputs, CommitWritesEveryOutput) {
  const std::string a = (dir() / "a.txt").string(), b = (dir() / "b.txt").string();
  std::ofstream(a) << "old a";
  {
    cli::StagedOutputs outputs;
    outputs.write(a, [](const std::string& tmp) { write_file_atomically(tmp, "new a"); });
    outputs.write(b, [](const std::string& tmp) { write_file_atomically(tmp, "new b"); });
    EXPECT_EQ(slurp(a), "old a");  // nothing is visible before the commit
    outputs.commit();
  }
  EXPECT_EQ(slurp(a), "new a");
  EXPECT_EQ(slurp(b), "new b");
  EXPECT_TRUE(temporaries(dir()).empty());
}

// An output that exists and is not a regular file (a FIFO, a device such as /dev/null) is refused:
// the rename would replace it with a regular file.
TEST(CliCompare, AnOutputThatIsNotARegularFileIsRefused) {
  const std::string ref = grey_exr("nref.exr", 2, 1, {1, 1});
  const std::string fifo = (dir() / "fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const CommandResult r = lamina("compare " + ref + " " + ref + " --json " + fifo);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--json '" + fifo + "' exists and is not a regular file"), std::string::npos) << r.err;
  struct stat st;
  ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

// --fail-above nan turned the CI gate off (exit 0 whatever the difference); now it is refused.
TEST(CliCompare, NonFiniteNumbersAreRefused) {
  const std::string ref = grey_exr("fref.exr", 2, 1, {1, 1});
  const std::string test = grey_exr("ftest.exr", 2, 1, {1.2f, 0.8f});
  for (const std::string opt : {"--fail-above nan", "--fail-above inf", "--range nan", "--range inf", "--epsilon nan",
                                "--epsilon 1e999", "--range 0x1p-1"}) {
    const CommandResult r = lamina("compare " + ref + " " + test + " " + opt);
    EXPECT_EQ(r.exit_code, 2) << opt;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << opt << ": " << r.err;
    EXPECT_EQ(r.err.rfind("lamina compare: " + opt.substr(0, opt.find(' ')) + ": must be a finite number", 0), 0u)
        << opt << ": " << r.err;
  }
}

}  // namespace
}  // namespace lamina
