// `lamina denoise` as a user runs it on a tiny render: the denoised image is closer to a long
// reference than the noisy one (OIDN with the albedo and normal AOVs), the raw render is left as
// it was, and bad input is one line and a non-zero exit.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using testing::GltfBuilder;
using testing::TempDir;

// A floor with a box on it under a uniform sky: the box's contact shadow and the floor's
// occlusion are noisy at low spp and smooth in the reference.
void write_scene(const std::string& path) {
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-3, 0, 3, 3, 0, 3, 3, 0, -3, -3, 0, -3}, {0, 1, 2, 0, 2, 3})}});
  const std::vector<float> box = {-0.6f, 0.0f, -0.6f, 0.6f, 0.0f, -0.6f, 0.6f, 1.2f, -0.6f, -0.6f, 1.2f, -0.6f,
                                  -0.6f, 0.0f, 0.6f,  0.6f, 0.0f, 0.6f,  0.6f, 1.2f, 0.6f,  -0.6f, 1.2f, 0.6f};
  b.add_node({{"mesh", b.add_mesh(box, {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 3, 6, 2, 3, 7, 6, 0, 4, 7, 0, 7, 3,
                                        1, 2, 6, 1, 6, 5})}});
  b.json()["cameras"] = {{{"name", "view"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.9}, {"znear", 0.1}}}}};
  b.add_node({{"camera", 0}, {"translation", {0.0, 2.5, 4.0}}, {"rotation", {-0.2588190, 0.0, 0.0, 0.9659258}}});
  b.write_gltf(path);
}

test::CliResult run(const TempDir& dir, const std::string& args) { return test::run_lamina(dir.path, args); }

TEST(DenoiseCli, CloserToTheReferenceThanTheNoisyRender) {
  TempDir dir("denoise");
  write_scene(dir / "s.gltf");
  const std::string size = " --width 48 --height 36 --env 1 --threads 2";
  ASSERT_EQ(run(dir, "render " + dir / "s.gltf -o " + dir / "ref.exr --spp 1024" + size).exit_code, 0);
  const auto noisy = run(dir, "render " + dir / "s.gltf -o " + dir / "noisy.exr --spp 4 --aovs albedo,normal" + size);
  ASSERT_EQ(noisy.exit_code, 0) << noisy.err;
  const ChannelImage channels = read_channels(dir / "noisy.exr");
  for (const char* name : {"albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z"}) EXPECT_GE(channels.find(name), 0) << name;
  const std::string before = test::slurp(dir / "noisy.exr");

  const auto r = run(dir, "denoise " + dir / "noisy.exr -o " + dir / "clean.exr --png " + dir / "clean.png");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("guided by albedo, normal"), std::string::npos) << r.out;
  EXPECT_EQ(test::slurp(dir / "noisy.exr"), before) << "the raw render must stay as it was";
  EXPECT_TRUE(std::filesystem::exists(dir / "clean.png"));
  bool marked = false;
  for (const auto& [k, v] : read_metadata(dir / "clean.exr")) marked |= k == "lamina:denoised" && v.find("Open Image Denoise") == 0;
  EXPECT_TRUE(marked);

  const Image ref = read_image(dir / "ref.exr");
  const double rmse_noisy = compare_images(ref, read_image(dir / "noisy.exr")).rmse;
  const double rmse_clean = compare_images(ref, read_image(dir / "clean.exr")).rmse;
  // The reference's own noise (1024 spp) is 16x below the noisy image's; OIDN should remove
  // most of the rest. A denoiser that passed the image through, or blurred it into a wrong
  // shading, would fail this.
  EXPECT_LT(rmse_clean, 0.5 * rmse_noisy) << "noisy " << rmse_noisy << ", denoised " << rmse_clean;

  // Without the AOVs: it still denoises, and says that it uses the colour alone.
  const auto plain = run(dir, "denoise " + dir / "ref.exr -o " + dir / "ref_dn.exr");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_NE(plain.err.find("no albedo AOV"), std::string::npos) << plain.err;
}

TEST(DenoiseCli, BadInputIsOneLine) {
  TempDir dir("denoise-bad");
  auto one_line = [](const test::CliResult& r, int code, const std::string& what) {
    EXPECT_EQ(r.exit_code, code) << r.err;
    std::string err = r.err;
    while (!err.empty() && err.back() == '\n') err.pop_back();
    EXPECT_EQ(err.find('\n'), std::string::npos) << r.err;
    EXPECT_NE(err.find(what), std::string::npos) << r.err;
  };
  one_line(run(dir, "denoise " + dir / "missing.exr -o " + dir / "out.exr"), 2, "missing.exr");
  EXPECT_FALSE(std::filesystem::exists(dir / "out.exr"));
  Image im(4, 4);
  write_exr(dir / "in.exr", im);
  one_line(run(dir, "denoise " + dir / "in.exr -o " + dir / "in.exr"), 2, "is the input");
  one_line(run(dir, "denoise " + dir / "in.exr -o " + dir / "nodir/out.exr"), 2, "does not exist");
  // An all-black image denoises to (nearly: the network's own offsets are ~1e-4) black (--no-aux:
  // the colour alone, no warning).
  const auto black = run(dir, "denoise " + dir / "in.exr -o " + dir / "out.exr --no-aux");
  ASSERT_EQ(black.exit_code, 0) << black.err;
  EXPECT_EQ(black.err, "");
  for (float v : read_image(dir / "out.exr").rgb) EXPECT_LT(std::abs(v), 1e-3f);
  // $LAMINA_OIDN_LIBRARY names the library: one that is not there is exit 1, naming it, and no output.
  ::setenv("LAMINA_OIDN_LIBRARY", "/nonexistent/libOpenImageDenoise.so.2", 1);
  const auto missing = run(dir, "denoise " + dir / "in.exr -o " + dir / "out2.exr --no-aux");
  ::unsetenv("LAMINA_OIDN_LIBRARY");
  one_line(missing, 1, "/nonexistent/libOpenImageDenoise.so.2");
  EXPECT_FALSE(std::filesystem::exists(dir / "out2.exr"));
}

// No output may be the input, under any name: the same path, a symbolic link or a hard link to
// it, for -o and for --png. The raw render stays byte for byte, and nothing is written.
TEST(DenoiseCli, NoOutputIsTheInputUnderAnyName) {
  TempDir dir("denoise-input");
  Image im(4, 4);
  write_exr(dir / "in.exr", im);
  const std::string before = test::slurp(dir / "in.exr");
  std::filesystem::create_symlink(dir / "in.exr", dir / "link.exr");
  std::filesystem::create_hard_link(dir / "in.exr", dir / "hard.exr");
  const std::string other_spelling = "./../" + std::filesystem::path(dir.path).filename().string() + "/in.exr";
  for (const std::string& name : {std::string("in.exr"), std::string("link.exr"), std::string("hard.exr"), other_spelling}) {
    for (const std::string option : {"--png", "-o"}) {
      const std::string args = option == "--png" ? "-o " + dir / "out.exr --png " + dir / name : "-o " + dir / name;
      const auto r = run(dir, "denoise " + dir / "in.exr " + args + " --no-aux");
      EXPECT_EQ(r.exit_code, 2) << option << " " << name << ": " << r.err;
      EXPECT_NE(r.err.find("is the input"), std::string::npos) << r.err;
      EXPECT_EQ(test::slurp(dir / "in.exr"), before) << option << " " << name;
      EXPECT_FALSE(std::filesystem::exists(dir / "out.exr"));
    }
  }
}

// A denoised crop keeps the crop's data and display windows: its pixels stay where the render
// put them, consistent with the lamina:crop it keeps in its header.
TEST(DenoiseCli, ACropKeepsItsWindows) {
  TempDir dir("denoise-crop");
  write_scene(dir / "s.gltf");
  const auto r = run(dir, "render " + dir / "s.gltf -o " + dir / "crop.exr --width 32 --height 24 --spp 2 --env 1 --crop 5,3,21,15");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto d = run(dir, "denoise " + dir / "crop.exr -o " + dir / "dn.exr --no-aux");
  ASSERT_EQ(d.exit_code, 0) << d.err;
  const ChannelImage in = read_channels(dir / "crop.exr"), out = read_channels(dir / "dn.exr");
  EXPECT_EQ(in.window.x, 5);
  EXPECT_EQ(in.window.y, 3);
  EXPECT_EQ(in.window.full_width, 32);
  EXPECT_EQ(in.window.full_height, 24);
  EXPECT_EQ(out.width, 16);
  EXPECT_EQ(out.height, 12);
  EXPECT_EQ(out.window.x, in.window.x);
  EXPECT_EQ(out.window.y, in.window.y);
  EXPECT_EQ(out.window.full_width, in.window.full_width);
  EXPECT_EQ(out.window.full_height, in.window.full_height);
}

}  // namespace
}  // namespace lamina
