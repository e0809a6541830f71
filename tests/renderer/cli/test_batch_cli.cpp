// `lamina batch` as a user runs it: outputs (images, diffs, contact sheet, summary CSV),
// resuming (only missing or stale jobs re-render, finished outputs are not touched), a killed
// batch leaves no partial EXR, a failing job does not stop the others, shards and finalize, and
// bad input.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/batch/batch_manifest.h"
#include "renderer/image/contact_sheet.h"
#include "renderer/image/false_colour.h"
#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/batch_fixture.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::TempDir;

using Result = test::CliResult;
using test::slurp;

// `lamina batch ARGS`.
Result batch(const TempDir& dir, const std::string& args) { return test::run_lamina(dir.path, "batch " + args); }

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> v;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) v.push_back(line);
  return v;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> v;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) v.push_back(field);
  if (!line.empty() && line.back() == ',') v.push_back("");
  return v;
}

// Modification time in nanoseconds (0 if missing).
long long mtime_ns(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return 0;
  return static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
}

// 2 lightings x 2 modes x 2 spp = 8 jobs on the quad; spp 4 against spp 16.
json small_manifest(int width = 24, int height = 18, std::vector<int> spp = {4, 16}) {
  return {{"lamina_batch", 1},
          {"settings", {{"width", width}, {"height", height}, {"seed", 7}, {"max_depth", 4}}},
          {"scenes", {{{"name", "quad"}, {"file", "quad.gltf"}}}},
          {"lighting", {{{"name", "grey"}, {"env", 1.0}}, {{"name", "blue"}, {"env", {0.2, 0.3, 1.0}}, {"camera", "front"}}}},
          {"modes", {"random-walk", "lambert"}},
          {"spp", spp},
          {"comparisons", {{{"name", "noise"}, {"reference", {{"spp", spp.back()}}}, {"test", json::object()}}}},
          {"contact_sheet", {{"columns", 4}, {"thumbnail_width", 48}}}};
}

struct BatchDir {
  TempDir dir;
  explicit BatchDir(const std::string& name, const json& manifest = small_manifest()) : dir(name) {
    testing::write_batch_quad(dir / "quad.gltf");
    testing::write_json(dir / "m.json", manifest);
  }
  std::string out() const { return dir / "out"; }
  std::string exr(const std::string& id) const { return dir / ("out/jobs/" + id + ".exr"); }
  std::vector<BatchJob> jobs() const { return expand_jobs(load_manifest(dir / "m.json")); }
};

TEST(BatchCli, WritesImagesDiffsSheetAndSummary) {
  BatchDir b("batch-outputs");
  const Result r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("8 jobs: 8 rendered, 0 already complete, 0 failed"), std::string::npos) << r.out;
  const std::vector<BatchJob> jobs = b.jobs();
  ASSERT_EQ(jobs.size(), 8u);
  for (const BatchJob& job : jobs) {
    SCOPED_TRACE(job.id);
    const Metadata meta = read_metadata(b.exr(job.id));
    std::map<std::string, std::string> m(meta.begin(), meta.end());
    EXPECT_EQ(m["lamina:job_hash"], job.hash);
    EXPECT_EQ(m["lamina:job_id"], job.id);
    EXPECT_EQ(m["lamina:spp"], std::to_string(job.spp));
    EXPECT_EQ(m["lamina:subsurface"], job.mode);
    EXPECT_EQ(m["lamina:seed"], "7");
    const Image image = read_image(b.exr(job.id));
    EXPECT_EQ(image.width, 24);
    EXPECT_EQ(image.height, 18);
    EXPECT_TRUE(fs::exists(b.dir / ("out/jobs/" + job.id + ".png")));
  }
  // The environment reaches the image: the blue set-up is bluer than the grey one.
  const Image grey = read_image(b.exr("quad__base__grey__random-walk__spp16"));
  const Image blue = read_image(b.exr("quad__base__blue__random-walk__spp16"));
  EXPECT_GT(blue.pixel(0, 0)[2] / blue.pixel(0, 0)[0], 2.0f);
  EXPECT_NEAR(grey.pixel(0, 0)[2] / grey.pixel(0, 0)[0], 1.0f, 1e-5f);

  // Summary: the documented columns, one row per job in job order; error columns for the four
  // 4 spp jobs (the tests of "noise"), empty for the 16 spp references.
  const std::vector<std::string> csv = lines(slurp(b.dir / "out/summary.csv"));
  ASSERT_EQ(csv.size(), 9u);
  EXPECT_EQ(csv[0], "job,scene,variant,lighting,mode,spp,seconds,rays_per_second,rmse_vs_reference,rel_rms_vs_reference,auto_choices");
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const std::vector<std::string> f = split(csv[i + 1]);
    ASSERT_EQ(f.size(), 11u) << csv[i + 1];
    EXPECT_EQ(f[10], "");  // no auto mode in this batch
    EXPECT_EQ(f[0], jobs[i].id);
    EXPECT_EQ(f[4], jobs[i].mode);
    EXPECT_EQ(f[5], std::to_string(jobs[i].spp));
    EXPECT_GT(std::stod(f[6]), 0.0);
    EXPECT_GT(std::stod(f[7]), 0.0);
    if (jobs[i].spp == 4) {
      EXPECT_GT(std::stod(f[8]), 0.0);
      EXPECT_GT(std::stod(f[9]), 0.0);
    } else {
      EXPECT_EQ(f[8], "");
      EXPECT_EQ(f[9], "");
    }
  }
  const std::vector<std::string> cmp = lines(slurp(b.dir / "out/comparisons.csv"));
  ASSERT_EQ(cmp.size(), 5u);
  EXPECT_EQ(cmp[0], "comparison,reference,test,mean_relative,rms_relative,max_abs_relative,rmse,ssim");
  for (const BatchJob& job : jobs)
    if (job.spp == 4) {
      EXPECT_TRUE(fs::exists(b.dir / ("out/diffs/noise__" + job.id + ".exr"))) << job.id;
      EXPECT_TRUE(fs::exists(b.dir / ("out/diffs/noise__" + job.id + ".png"))) << job.id;
    }

  // Contact sheet: 8 images + 4 diffs in 4 columns of 48 px thumbnails (24 x 18 -> 48 x 36),
  // the label band as tall as the longest label wrapped to 48 px: a difference names its
  // comparison, range and smoothing, the axes its jobs share, and REF and TEST by the axis they
  // differ in (spp here).
  int label_lines = kSheetLabelLines;
  for (const BatchJob& job : jobs) {
    const std::string mode_spp = job.mode + ", " + std::to_string(job.spp) + " spp";
    std::vector<std::vector<std::string>> labels = {{"quad / base / " + job.lighting, mode_spp}};
    if (job.spp == 4)
      labels.push_back({"diff noise", "+-25%, sigma 2 px", "quad / base / " + job.lighting + ", " + job.mode, "REF 16 spp", "TEST 4 spp"});
    for (const std::vector<std::string>& label : labels)
      label_lines = std::max(label_lines, static_cast<int>(contact_label_lines(ContactCell{Image(1, 1), label}, 48).size()));
  }
  EXPECT_GT(label_lines, 5);  // the differences' labels wrap on 48 px
  const Image sheet = read_image(b.dir / "out/contact_sheet.png");
  const int cell_h = 36 + label_lines * kSheetLineHeight;
  EXPECT_EQ(sheet.width, kSheetPadding + 4 * (48 + kSheetPadding));
  EXPECT_EQ(sheet.height, kSheetPadding + 3 * (cell_h + kSheetPadding));
}

// A difference picture is `lamina compare --smooth`'s: both renders smoothed by the manifest's
// contact_sheet.diff_smooth (default 2 px, 0 for none) over the reference's non-black pixels,
// in false colour at +-diff_range, the legend naming the smoothing, and REF and TEST named in
// notes under it. The metrics and the EXR stay per pixel.
TEST(BatchCli, DifferencePicturesAreSmoothedAndNameRefAndTest) {
  BatchDir b("batch-diff-pictures");
  ASSERT_EQ(batch(b.dir, b.dir / "m.json --out " + b.out()).exit_code, 0);
  const std::string ref_id = "quad__base__grey__random-walk__spp16", test_id = "quad__base__grey__random-walk__spp4";
  const Image ref = read_image(b.exr(ref_id)), test = read_image(b.exr(test_id));
  const std::string png = b.dir / ("out/diffs/noise__" + test_id + ".png");
  const std::string exr = b.dir / ("out/diffs/noise__" + test_id + ".exr");
  const std::vector<std::string> notes = {"REF: quad / base / grey, random-walk, 16 spp",
                                          "TEST: quad / base / grey, random-walk, 4 spp"};
  // The expected picture through the same PNG encoding.
  auto expected_png = [&](double sigma) {
    const ImagePair shown = smoothed_pair(ref, test, sigma);
    const std::vector<float> rel = relative_luminance_difference(shown.reference, shown.test);
    const std::string path = b.dir / ("expected-" + std::to_string(sigma) + ".png");
    write_png(path, false_colour_with_legend(rel, ref.width, ref.height, 0.25, difference_caption(sigma), notes));
    return read_image(path);
  };
  // Mean square of the map's red minus blue: the picture's visible difference.
  auto contrast = [&](const Image& picture) {
    double sum = 0.0;
    for (int y = 0; y < ref.height; ++y)
      for (int x = 0; x < ref.width; ++x) sum += std::pow(picture.pixel(x, y)[0] - picture.pixel(x, y)[2], 2);
    return sum;
  };
  const Image smoothed = read_image(png);
  EXPECT_EQ(smoothed.rgb, expected_png(2.0).rgb);
  EXPECT_EQ(smoothed.height, ref.height + kLegendHeight + kLegendNotesMargin +
                                 static_cast<int>(legend_note_lines(notes, smoothed.width).size()) * kLegendNoteLineHeight);
  const Image raw_exr = read_image(exr);
  EXPECT_EQ(raw_exr.rgb, relative_difference(ref, test, relative_guard_floor(ref)).rgb);  // per pixel

  json m = small_manifest();
  m["contact_sheet"]["diff_smooth"] = 0;
  testing::write_json(b.dir / "raw.json", m);
  ASSERT_EQ(batch(b.dir, b.dir / "raw.json --finalize --out " + b.out()).exit_code, 0);
  const Image raw = read_image(png);
  EXPECT_EQ(raw.rgb, expected_png(0.0).rgb);
  EXPECT_LT(contrast(smoothed), 0.5 * contrast(raw));  // the noise is averaged away
  EXPECT_EQ(read_image(exr).rgb, raw_exr.rgb);          // the EXR does not depend on the smoothing

  // The option: a Gaussian sigma in pixels in [0, 64], 2 when not given.
  EXPECT_EQ(load_manifest(b.dir / "m.json").contact_sheet.diff_smooth, 2.0);
  EXPECT_EQ(load_manifest(b.dir / "raw.json").contact_sheet.diff_smooth, 0.0);
  for (const json& bad : {json(-1), json(64.5), json("2"), json(true)}) {
    m["contact_sheet"]["diff_smooth"] = bad;
    testing::write_json(b.dir / "bad.json", m);
    try {
      load_manifest(b.dir / "bad.json");
      ADD_FAILURE() << bad.dump() << " accepted";
    } catch (const ManifestError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.json: contact_sheet.diff_smooth: expected a Gaussian sigma in pixels in [0, 64]"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(BatchCli, ResumesOnlyMissingOrStaleJobs) {
  BatchDir b("batch-resume");
  ASSERT_EQ(batch(b.dir, b.dir / "m.json --out " + b.out()).exit_code, 0);
  const std::vector<BatchJob> jobs = b.jobs();
  std::map<std::string, long long> before;
  for (const BatchJob& job : jobs) before[job.id] = mtime_ns(b.exr(job.id));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // so a rewrite shows in mtimes

  Result r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("8 jobs: 0 rendered, 8 already complete"), std::string::npos) << r.out;
  for (const BatchJob& job : jobs) EXPECT_EQ(mtime_ns(b.exr(job.id)), before[job.id]) << job.id;

  // One output deleted, one replaced by an EXR of another job (its hash does not match).
  fs::remove(b.exr(jobs[3].id));
  fs::copy_file(b.exr(jobs[0].id), b.exr(jobs[5].id), fs::copy_options::overwrite_existing);
  const long long stale = mtime_ns(b.exr(jobs[5].id));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("8 jobs: 2 rendered, 6 already complete"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(jobs[3].id + ": rendering"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(jobs[5].id + ": rendering"), std::string::npos) << r.out;
  for (const BatchJob& job : jobs) {
    if (job.index == 3 || job.index == 5) continue;
    EXPECT_EQ(mtime_ns(b.exr(job.id)), before[job.id]) << job.id;
  }
  EXPECT_GT(mtime_ns(b.exr(jobs[5].id)), stale);
  bool hash_ok = false;
  for (const auto& [k, v] : read_metadata(b.exr(jobs[5].id))) hash_ok = hash_ok || (k == "lamina:job_hash" && v == jobs[5].hash);
  EXPECT_TRUE(hash_ok);

  // A changed setting changes every hash: everything re-renders. --force re-renders too.
  json changed = small_manifest();
  changed["settings"]["seed"] = 8;
  testing::write_json(b.dir / "m.json", changed);
  r = batch(b.dir, b.dir / "m.json --out " + b.out());
  EXPECT_NE(r.out.find("8 jobs: 8 rendered, 0 already complete"), std::string::npos) << r.out;
  r = batch(b.dir, b.dir / "m.json --out " + b.out() + " --force");
  EXPECT_NE(r.out.find("8 jobs: 8 rendered, 0 already complete"), std::string::npos) << r.out;
}

// Completion means a readable file: a job EXR whose header carries the hash but whose pixels
// are cut off, or a preview of the job (lamina:preview), is rendered again on the next run.
TEST(BatchCli, TruncatedOrPreviewJobIsRenderedAgain) {
  BatchDir b("batch-truncated");
  ASSERT_EQ(batch(b.dir, b.dir / "m.json --out " + b.out()).exit_code, 0);
  const std::vector<BatchJob> jobs = b.jobs();
  const std::string truncated = b.exr(jobs[2].id);
  const std::uintmax_t size = fs::file_size(truncated);
  fs::resize_file(truncated, size - size / 4);
  ASSERT_NO_THROW(read_metadata(truncated));  // the header with its hash is intact
  bool hash_kept = false;
  for (const auto& [k, v] : read_metadata(truncated)) hash_kept = hash_kept || (k == "lamina:job_hash" && v == jobs[2].hash);
  ASSERT_TRUE(hash_kept);
  // A preview of job 4 carrying job 4's hash, as a killed --preview-every render would leave.
  Metadata preview = read_metadata(b.exr(jobs[4].id));
  preview.emplace_back("lamina:preview", "0.5");
  write_exr(b.exr(jobs[4].id), read_image(b.exr(jobs[4].id)), preview);

  Result r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("8 jobs: 2 rendered, 6 already complete"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(jobs[2].id + ": rendering"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(jobs[4].id + ": rendering"), std::string::npos) << r.out;
  EXPECT_NO_THROW(read_channels(truncated));
}

// Every EXR in the output is complete: it carries its job's hash.
void expect_only_complete_exrs(const BatchDir& b, std::size_t* complete) {
  std::map<std::string, std::string> hash_of;
  for (const BatchJob& job : b.jobs()) hash_of[job.id + ".exr"] = job.hash;
  *complete = 0;
  for (const auto& e : fs::directory_iterator(b.dir / "out/jobs")) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".exr") continue;
    ASSERT_TRUE(hash_of.count(name)) << "unexpected file " << name;
    std::string hash;
    ASSERT_NO_THROW({
      for (const auto& [k, v] : read_metadata(e.path().string()))
        if (k == "lamina:job_hash") hash = v;
    }) << name;
    EXPECT_EQ(hash, hash_of[name]) << name;
    read_image(e.path().string());  // the pixels read back
    ++*complete;
  }
}

TEST(BatchCli, KilledBatchLeavesNoPartialOutputAndResumes) {
  // Jobs of a fraction of a second each, so a kill lands in the middle of the batch.
  BatchDir b("batch-kill", small_manifest(96, 72, {64, 256}));
  const std::string first = b.exr(b.jobs()[0].id);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string out_file = b.dir / "killed_stdout.txt";
    std::freopen(out_file.c_str(), "w", stdout);
    std::freopen(out_file.c_str(), "a", stderr);
    const std::string m = b.dir / "m.json";
    const std::string out = b.out();
    ::execl(LAMINA_EXE, LAMINA_EXE, "batch", m.c_str(), "--out", out.c_str(), "--threads", "1", static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  // Wait for the first job's EXR, then kill the batch without warning.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(first) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the batch ended before it was killed: " << slurp(b.dir / "killed_stdout.txt");

  std::size_t complete = 0;
  expect_only_complete_exrs(b, &complete);
  ASSERT_GE(complete, 1u);
  ASSERT_LT(complete, 8u) << "all jobs finished before the kill: nothing was tested";
  EXPECT_FALSE(fs::exists(b.dir / "out/summary.csv"));

  const Result r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("8 jobs: " + std::to_string(8 - complete) + " rendered, " + std::to_string(complete) + " already complete"),
            std::string::npos)
      << r.out;
  expect_only_complete_exrs(b, &complete);
  EXPECT_EQ(complete, 8u);
  for (const auto& e : fs::directory_iterator(b.dir / "out/jobs"))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << "temporary file left: " << e.path();
}

TEST(BatchCli, FailingJobDoesNotStopTheOthers) {
  json m = small_manifest();
  m["lighting"][1]["env"] = "broken.exr";  // exists, but is no image: that job's render fails
  BatchDir b("batch-fail", m);
  std::ofstream(b.dir / "broken.exr") << "not an EXR";
  const Result r = batch(b.dir, b.dir / "m.json --out " + b.out());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("8 jobs: 4 rendered, 0 already complete, 4 failed"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("4 job(s) failed"), std::string::npos) << r.err;
  std::size_t complete = 0;
  expect_only_complete_exrs(b, &complete);
  EXPECT_EQ(complete, 4u);
  EXPECT_FALSE(fs::exists(b.dir / "out/summary.csv"));  // no summary of an incomplete batch
}

TEST(BatchCli, ShardsCoverTheBatchAndFinalizeCompletesIt) {
  BatchDir b("batch-shards");
  Result all = batch(b.dir, b.dir / "m.json --list");
  ASSERT_EQ(all.exit_code, 0) << all.err;
  const std::vector<std::string> every = lines(all.out);
  ASSERT_EQ(every.size(), 8u);
  for (int n : {3, 5}) {  // more n in tests/renderer (in_shard); here the CLI path
    std::multiset<std::string> seen;
    for (int i = 0; i < n; ++i) {
      const Result r = batch(b.dir, b.dir / "m.json --list --shard " + std::to_string(i) + "/" + std::to_string(n));
      ASSERT_EQ(r.exit_code, 0) << r.err;
      for (const std::string& line : lines(r.out)) seen.insert(line);
    }
    EXPECT_EQ(seen, std::multiset<std::string>(every.begin(), every.end())) << n << " shards";
  }

  // Finalize before the shards: an error naming what is missing.
  Result r = batch(b.dir, b.dir / "m.json --out " + b.out() + " --finalize");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("8 of 8 jobs have no complete output"), std::string::npos) << r.err;
  for (int i = 0; i < 3; ++i) {
    r = batch(b.dir, b.dir / "m.json --out " + b.out() + " --shard " + std::to_string(i) + "/3");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_FALSE(fs::exists(b.dir / "out/summary.csv"));
  }
  r = batch(b.dir, b.dir / "m.json --out " + b.out() + " --finalize");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(lines(slurp(b.dir / "out/summary.csv")).size(), 9u);
  EXPECT_TRUE(fs::exists(b.dir / "out/contact_sheet.png"));
}

// A mode {"subsurface": "auto", "tolerance": E}: rendered with --subsurface auto --tolerance E,
// what it chose per material in the summary's last column (read back from the EXR header, so
// also for skipped jobs), and a re-run skips it.
TEST(BatchCli, AutoModeChoicesInSummaryAndResume) {
  json m = small_manifest(12, 9, {2});
  m["scenes"][0]["materials"] = {{"skin", "stack.json"}};
  m["lighting"] = {{{"name", "grey"}, {"env", 1.0}}};
  m["modes"] = {"random-walk", {{"subsurface", "auto"}, {"tolerance", 0.05}}};
  m["comparisons"] = {{{"name", "auto"}, {"reference", {{"mode", "random-walk"}}}, {"test", {{"mode", "auto-0.05"}}}}};
  BatchDir b("batch-auto", m);
  // A thin, weakly scattering stack (optical depths ~1): the prediction's walks are short.
  testing::write_json(b.dir / "stack.json", json::parse(R"({
    "lamina_material": 1, "name": "thin", "above_ior": 1.0,
    "layers": [ { "name": "top", "ior": 1.3, "thickness": 0.05, "sigma_a": [0.5, 1.0, 2.0], "sigma_s": 10.0, "g": 0.3 } ],
    "below": { "lambert": 0.3 } })"));
  Result r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("2 jobs: 2 rendered, 0 already complete, 0 failed"), std::string::npos) << r.out;
  const std::vector<BatchJob> jobs = b.jobs();
  ASSERT_EQ(jobs.size(), 2u);
  ASSERT_EQ(jobs[1].id, "quad__base__grey__auto-0.05__spp2");

  // The header of the auto job: how it was rendered and what it chose for "skin".
  std::map<std::string, std::string> meta;
  for (const auto& [k, v] : read_metadata(b.exr(jobs[1].id))) meta[k] = v;
  EXPECT_EQ(meta["lamina:subsurface"], "auto");
  EXPECT_EQ(meta["lamina:tolerance"], "0.05");
  const std::string reason = meta["lamina:auto:skin"];
  std::string chosen;
  for (const char* mode : {"random-walk", "first-order", "table", "lambert"})
    if (reason.rfind(std::string("chose ") + mode + " (", 0) == 0) chosen = mode;
  ASSERT_FALSE(chosen.empty()) << "lamina:auto:skin = '" << reason << "'";
  EXPECT_EQ(meta["lamina:auto_mode:skin"], chosen) << "the machine-readable header agrees with the reason";
  for (const auto& [k, v] : read_metadata(b.exr(jobs[0].id))) EXPECT_NE(k.rfind("lamina:auto:", 0), 0u) << k;

  const std::string summary = slurp(b.dir / "out/summary.csv");
  const std::vector<std::string> csv = lines(summary);
  ASSERT_EQ(csv.size(), 3u);
  const std::vector<std::string> walk = split(csv[1]), automatic = split(csv[2]);
  ASSERT_EQ(walk.size(), 11u) << csv[1];
  ASSERT_EQ(automatic.size(), 11u) << csv[2];
  EXPECT_EQ(walk[4], "random-walk");
  EXPECT_EQ(walk[10], "");
  EXPECT_EQ(automatic[4], "auto-0.05");
  EXPECT_EQ(automatic[10], "skin=" + chosen);
  EXPECT_NE(automatic[8], "");  // the test of comparison "auto"
  EXPECT_TRUE(fs::exists(b.dir / ("out/diffs/auto__" + jobs[1].id + ".exr")));

  // Resume: nothing re-renders (no second prediction either), and the summary is the same,
  // its auto_choices read from the existing EXR.
  const long long before = mtime_ns(b.exr(jobs[1].id));
  r = batch(b.dir, b.dir / "m.json --out " + b.out());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("2 jobs: 0 rendered, 2 already complete"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("auto: material"), std::string::npos) << r.out;
  EXPECT_EQ(mtime_ns(b.exr(jobs[1].id)), before);
  EXPECT_EQ(slurp(b.dir / "out/summary.csv"), summary);
}

TEST(BatchCli, BadInputIsOneLineAndNonZero) {
  BatchDir b("batch-bad");
  json m = small_manifest();
  m["modes"] = {"photon"};
  testing::write_json(b.dir / "bad.json", m);
  for (const std::string& args : {b.dir / "bad.json", b.dir / "missing.json", b.dir / "m.json --shard 3/3",
                                  b.dir / "m.json --shard 1/2 --finalize", std::string("")}) {
    SCOPED_TRACE(args);
    const Result r = batch(b.dir, args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    std::string err = r.err;
    while (!err.empty() && err.back() == '\n') err.pop_back();
    EXPECT_FALSE(err.empty());
    EXPECT_EQ(err.find('\n'), std::string::npos) << r.err;
  }
  const Result r = batch(b.dir, b.dir / "bad.json");
  EXPECT_NE(r.err.find("bad.json: modes[0]: unknown mode 'photon'"), std::string::npos) << r.err;
  EXPECT_EQ(batch(b.dir, "--help").exit_code, 0);
}

}  // namespace
}  // namespace lamina
