// `lamina render` as a user runs it: bad input gives one line on stderr naming the file and the
// problem, a non-zero exit, no crash and no output file; good input writes the EXR (and PNG)
// with its metadata.
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "tests/support/image_files.h"
#include <gtest/gtest.h>

#include "renderer/image/image_io.h"
#include "renderer/render/render_job.h"
#include "renderer/render/render_request_check.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using testing::GltfBuilder;
using testing::TempDir;

using Result = test::CliResult;
using test::slurp;

// `lamina render ARGS`.
Result run(const TempDir& dir, const std::string& args) { return test::run_lamina(dir.path, "render " + args); }

// A unit quad facing +Z, in front of the default framing camera.
void write_quad(const std::string& path, bool glb = false) {
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3})}});
  glb ? b.write_glb(path) : b.write_gltf(path);
}

// The error is one line, names `file`, and mentions `what`; nothing was written.
void expect_failure(const Result& r, const std::string& file, const std::string& what, const std::string& out) {
  EXPECT_NE(r.exit_code, 0);
  EXPECT_LT(r.exit_code, 128) << "crashed: " << r.err;
  std::string err = r.err;
  while (!err.empty() && err.back() == '\n') err.pop_back();
  EXPECT_EQ(err.find('\n'), std::string::npos) << "more than one line: " << r.err;
  EXPECT_NE(err.find(file), std::string::npos) << r.err;
  EXPECT_NE(err.find(what), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out)) << out;
}

TEST(RenderCli, RendersAndWritesMetadata) {
  TempDir dir("cli-ok");
  write_quad(dir / "quad.gltf");
  const Result r = run(dir, dir / "quad.gltf" + " -o " + dir / "q.exr" + " --png " + dir / "q.png" +
                                " --width 16 --height 12 --spp 2 --env 1 --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image im = read_image(dir / "q.exr");
  EXPECT_EQ(im.width, 16);
  EXPECT_EQ(im.height, 12);
  EXPECT_TRUE(std::filesystem::exists(dir / "q.png"));
  bool spp = false, rays = false, seconds = false, command = false, version = false;
  for (const auto& [k, v] : read_metadata(dir / "q.exr")) {
    spp |= k == "lamina:spp" && v == "2";
    rays |= k == "lamina:rays_closest" && std::stod(v) >= 16 * 12 * 2;
    seconds |= k == "lamina:seconds";
    command |= k == "lamina:command" && v.find("--spp 2") != std::string::npos;
    version |= k == "lamina:version";
  }
  EXPECT_TRUE(spp && rays && seconds && command && version);
  EXPECT_NE(r.out.find("spp"), std::string::npos);
  EXPECT_NE(r.out.find("peak memory"), std::string::npos);
}

// --camera picks a camera by name; --env reads an equirectangular EXR. The quad is emissive-free
// and lit by a uniform EXR environment, so every pixel is finite and non-negative.
TEST(RenderCli, NamedCameraAndEnvironmentFile) {
  TempDir dir("cli-camera");
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3})}});
  b.json()["cameras"] = {{{"name", "near"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}},
                         {{"name", "far"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}}};
  b.add_node({{"camera", 0}, {"translation", {0, 0, 2}}});
  b.add_node({{"camera", 1}, {"translation", {0, 0, 50}}});
  b.write_gltf(dir / "cams.gltf");
  Image sky(8, 4);
  for (float& v : sky.rgb) v = 0.5f;
  write_exr(dir / "sky.exr", sky);
  const Result r = run(dir, dir / "cams.gltf -o " + dir / "far.exr" + " --camera far --env " + dir / "sky.exr" +
                                " --width 8 --height 8 --spp 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  bool far = false;
  for (const auto& [k, v] : read_metadata(dir / "far.exr")) far |= k == "lamina:camera" && v == "far";
  EXPECT_TRUE(far);
  const Image im = read_image(dir / "far.exr");
  // From 50 units a 2-unit quad covers ~0.07 of the view: the corner pixel sees the sky (0.5).
  EXPECT_NEAR(im.pixel(0, 0)[0], 0.5, 1e-3);
  for (float v : im.rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
}

// A camera's aspectRatio does not set the image's shape (--width/--height does): when they
// differ, one warning says so, naming the camera; when they agree, nothing is said.
TEST(RenderCli, ACameraAspectRatioThatDoesNotActIsAWarning) {
  TempDir dir("cli-aspect");
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3})}});
  b.json()["cameras"] = {{{"name", "wide"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"aspectRatio", 2.0}, {"znear", 0.1}}}}};
  b.add_node({{"camera", 0}, {"translation", {0, 0, 4}}});
  b.write_gltf(dir / "wide.gltf");
  const Result square = run(dir, dir / "wide.gltf -o " + dir / "a.exr --width 8 --height 8 --spp 1 --env 1");
  ASSERT_EQ(square.exit_code, 0) << square.err;
  EXPECT_NE(square.err.find("warning: " + dir / "wide.gltf" + ": camera 'wide': aspectRatio 2 is not used"), std::string::npos)
      << square.err;
  const Result matched = run(dir, dir / "wide.gltf -o " + dir / "b.exr --width 16 --height 8 --spp 1 --env 1");
  ASSERT_EQ(matched.exit_code, 0) << matched.err;
  EXPECT_EQ(matched.err.find("aspectRatio"), std::string::npos) << matched.err;
}

TEST(RenderCli, BadScenesFailCleanly) {
  TempDir dir("cli-bad");
  const std::string out = dir / "out.exr";
  write_quad(dir / "ok.glb", true);
  {
    std::ifstream in(dir / "ok.glb", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.glb", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
    expect_failure(run(dir, dir / "cut.glb -o " + out), dir / "cut.glb", "", out);
  }
  {
    std::ofstream(dir / "garbage.glb") << "this is not a glTF file";
    expect_failure(run(dir, dir / "garbage.glb -o " + out), dir / "garbage.glb", "", out);
  }
  {
    GltfBuilder b;
    b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0})}});
    b.write_gltf(dir / "ext.gltf", "ext.bin");
    std::filesystem::remove(dir / "ext.bin");
    expect_failure(run(dir, dir / "ext.gltf -o " + out), dir / "ext.gltf", "ext.bin", out);
  }
  {
    GltfBuilder b;
    b.json()["images"] = {{{"uri", "gone.png"}}};
    b.json()["textures"] = {{{"source", 0}}};
    b.json()["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
    b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
    b.write_gltf(dir / "tex.gltf");
    expect_failure(run(dir, dir / "tex.gltf -o " + out), dir / "tex.gltf", "gone.png", out);
  }
  {
    GltfBuilder b;
    b.add_node({{"name", "nothing here"}});
    b.write_gltf(dir / "empty.gltf");
    expect_failure(run(dir, dir / "empty.gltf -o " + out), dir / "empty.gltf", "no triangles", out);
  }
  {
    GltfBuilder b;
    b.add_node({{"mesh", b.add_mesh({0, 0, 0, NAN, 0, 0, 0, 1, 0})}});
    b.write_gltf(dir / "nan.gltf");
    expect_failure(run(dir, dir / "nan.gltf -o " + out), dir / "nan.gltf", "non-finite", out);
  }
  expect_failure(run(dir, dir / "missing.gltf -o " + out), dir / "missing.gltf", "", out);
}

TEST(RenderCli, DegenerateTrianglesAreSkippedAndCounted) {
  TempDir dir("cli-degenerate");
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, 0, 0, 0, 1, 1, 1, 2, 2, 2})}});
  b.write_gltf(dir / "d.gltf");
  const Result r = run(dir, dir / "d.gltf -o " + dir / "d.exr" + " --width 8 --height 8 --spp 1 --env 1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("1 degenerate triangle"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "d.exr"));
}

TEST(RenderCli, BadOptionsFailCleanly) {
  TempDir dir("cli-options");
  const std::string scene = dir / "quad.gltf";
  const std::string out = dir / "out.exr";
  write_quad(scene);
  expect_failure(run(dir, scene + " -o " + out + " --camera nosuch"), scene, "no camera named 'nosuch'", out);
  expect_failure(run(dir, scene + " -o " + out + " --width 100000"), "--width", "between", out);
  expect_failure(run(dir, scene + " -o " + out + " --height 0"), "--height", "between", out);
  expect_failure(run(dir, scene + " -o " + out + " --spp 0"), "--spp", "between", out);
  expect_failure(run(dir, scene + " -o " + out + " --spp -3"), "--spp", "between", out);
  expect_failure(run(dir, scene + " -o " + out + " --spp lots"), "--spp", "", out);
  expect_failure(run(dir, scene + " -o " + out + " --width 16384 --height 16384 --spp 1000000"), "--spp", "1e12", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface dipole"), "--subsurface 'dipole'", "random-walk", out);
  expect_failure(run(dir, scene + " -o " + out + " --tolerance 0.05"), "--tolerance", "--subsurface auto", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface first-order --tolerance 0.05"), "--tolerance", "--subsurface auto", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface auto"), "--subsurface auto", "--tolerance", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface auto --tolerance 0"), "--tolerance", "(0, 1]", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface auto --tolerance 2"), "--tolerance", "(0, 1]", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface auto --tolerance nan"), "--tolerance", "", out);
  expect_failure(run(dir, scene + " -o " + out + " --subsurface auto --tolerance lots"), "--tolerance", "", out);
  expect_failure(run(dir, scene + " -o " + out + " --env not-a-file.exr"), "not-a-file.exr", "", out);
  const std::string nodir = dir / "no/such/dir/out.exr";
  expect_failure(run(dir, scene + " -o " + nodir), nodir, "does not exist", nodir);
  expect_failure(run(dir, scene + " -o " + dir.path.string()), dir.path.string(), "is a directory", out);
  expect_failure(run(dir, scene + " -o " + out + " --png " + nodir), nodir, "does not exist", out);
}

}  // namespace
}  // namespace lamina

namespace lamina {
namespace {

// A glTF with one quad z = 0 in [-1, 1]^2 facing +z whose material is `material`, bound by
// DIR/map.json to DIR/<stack_file> holding `stack_json`: the scene of the layered CLI tests.
void write_layered_quad(const TempDir& dir, const std::string& gltf, const std::string& material,
                        const std::string& stack_file, const std::string& stack_json) {
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", material}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0)}});
  b.write_gltf(dir / gltf);
  std::filesystem::create_directories((dir.path / stack_file).parent_path());
  std::ofstream(dir / stack_file) << stack_json;
  std::ofstream(dir / "map.json") << nlohmann::json{{material, stack_file}}.dump();
}

// An output that is a stack file the material map names (found only when the map is read) is
// refused before anything is rendered, and the stack stays as it was.
TEST(RenderCliLayered, AnOutputThatIsAStackFileIsRefused) {
  TempDir dir("cli-stack-output");
  const std::string stack =
      R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 20, "g": 0.3}]})";
  write_layered_quad(dir, "leaf.gltf", "leaf", "m/leaf.json", stack);
  // -o names an EXR (a .json is refused by its extension first, exit 2); --png may name any file.
  for (const std::string outputs : {"-o " + dir / "m/leaf.json", "-o " + dir / "x.exr --png " + dir / "m/../m/leaf.json"}) {
    const bool by_extension = outputs.rfind("-o " + dir / "m/leaf.json", 0) == 0;
    const Result r = run(dir, dir / "leaf.gltf --materials " + dir / "map.json " + outputs + " --width 4 --height 4 --spp 1");
    EXPECT_EQ(r.exit_code, by_extension ? 2 : 1) << r.err;
    EXPECT_NE(r.err.find(by_extension ? "is not written" : "is the stack file"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(dir / "m/leaf.json"), stack);
    EXPECT_FALSE(std::filesystem::exists(dir / "x.exr"));
  }
}

// A quad whose material "leaf" is bound to a stack by --materials (path relative to the map),
// rendered in every --subsurface mode; the EXR records the layered counters. A map naming a
// missing stack file fails with one line naming the map, the material and the file.
TEST(RenderCliLayered, MaterialsMapAndModes) {
  TempDir dir("cli-layered");
  write_layered_quad(dir, "leaf.gltf", "leaf", "m/leaf.json",
                     R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": [0.5, 0.1, 0.8], "sigma_s": 20, "g": 0.3}], "below": {"ior": 1.0}})");
  // (table mode builds its tables from 4e5 walks: tested in tests/renderer, not here, for time)
  for (const char* mode : {"random-walk", "first-order", "lambert"}) {
    const std::string out = dir / (std::string(mode) + ".exr");
    const Result r = run(dir, dir / "leaf.gltf -o " + out + " --materials " + dir / "map.json" +
                                  " --width 6 --height 4 --spp 2 --env 1 --subsurface " + mode);
    ASSERT_EQ(r.exit_code, 0) << mode << ": " << r.err;
    bool bound = false, events = false;
    for (const auto& [k, v] : read_metadata(out)) {
      bound |= k == "lamina:layered_materials" && v == "1";
      events |= k == "lamina:scatter_events" && (std::string(mode) != "random-walk" || std::stod(v) > 0);
    }
    EXPECT_TRUE(bound && events) << mode;
    for (float v : read_image(out).rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f) << mode;
  }
  std::ofstream(dir / "bad_map.json") << R"({"leaf": "m/nothere.json"})";
  expect_failure(run(dir, dir / "leaf.gltf -o " + dir / "x.exr" + " --materials " + dir / "bad_map.json"),
                 dir / "bad_map.json", "nothere.json", dir / "x.exr");
}

// A diffuse interface (docs/layered_rendering.md, "Diffusely transmitting interfaces"): the walk
// renders one at the bottom (finite, non-negative pixels); first-order refuses it, and the walk
// one between two layers, each in one line naming the file and the JSON path.
TEST(RenderCliLayered, RendersDiffuseInterfacesAndRefusesThemWhereAModeCannot) {
  TempDir dir("cli-diffuse");
  write_layered_quad(dir, "leaf.gltf", "leaf", "m/leaf.json",
                     R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 20, "g": 0.3, "bottom_diffuse": true}], "below": {"ior": 1.0}})");
  const std::string args = " --materials " + dir / "map.json" + " --width 6 --height 4 --spp 2 --env 1 --subsurface ";
  const std::string out = dir / "walk.exr";
  const Result r = run(dir, dir / "leaf.gltf -o " + out + args + "random-walk");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (float v : read_image(out).rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
  expect_failure(run(dir, dir / "leaf.gltf -o " + dir / "x.exr" + args + "first-order"), "m/leaf.json",
                 "layers[0].bottom_diffuse: first-order does not model a diffuse interface", dir / "x.exr");
  write_layered_quad(dir, "inner.gltf", "leaf", "m/inner.json",
                     R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 20, "g": 0.3, "bottom_diffuse": true},
                         {"ior": 1.5, "thickness": 0.1, "sigma_a": 0.5, "sigma_s": 20, "g": 0.3}], "below": {"ior": 1.0}})");
  expect_failure(run(dir, dir / "inner.gltf -o " + dir / "x.exr" + args + "random-walk"), "m/inner.json",
                 "layers[0].bottom_diffuse: the walk renders a diffuse interface at the top or the bottom only", dir / "x.exr");
}

// A rough top (roughness 0.3): the first-order mode renders it through a mirror and says so, on
// stderr and in the header (lamina:ignored:MATERIAL); random-walk renders it and says nothing.
TEST(RenderCliLayered, ModesSayWhatTheyIgnore) {
  TempDir dir("cli-ignored");
  write_layered_quad(dir, "skin.gltf", "skin", "m/skin.json",
                     R"({"lamina_material": 1, "roughness": 0.3, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": [0.5, 0.1, 0.8], "sigma_s": 20, "g": 0.3}], "below": {"lambert": 0.5}})");
  for (const char* mode : {"random-walk", "first-order"}) {
    const std::string out = dir / (std::string(mode) + ".exr");
    const Result r = run(dir, dir / "skin.gltf -o " + out + " --materials " + dir / "map.json" +
                                  " --width 6 --height 4 --spp 2 --env 1 --subsurface " + mode);
    ASSERT_EQ(r.exit_code, 0) << mode << ": " << r.err;
    std::string ignored;
    for (const auto& [k, v] : read_metadata(out))
      if (k == "lamina:ignored:skin") ignored = v;
    const bool walk = std::string(mode) == "random-walk";
    if (walk) {
      EXPECT_EQ(r.err.find("ignores"), std::string::npos) << r.err;
      EXPECT_EQ(ignored, "");
    } else {
      EXPECT_NE(r.err.find("m/skin.json): the first-order mode ignores the roughness 0.3 of the top interface"),
                std::string::npos) << r.err;
      EXPECT_NE(ignored.find("the roughness 0.3 of the top interface"), std::string::npos) << ignored;
    }
  }
}

}  // namespace
}  // namespace lamina

namespace lamina {
namespace {

// --subsurface auto: a strongly absorbing stack (first order is within 5%: see
// tests/renderer/layered/test_subsurface_auto) on a visible quad, and a second layered material on a
// quad hidden behind it (no camera ray reaches it). The choice and its reason are printed and
// stored per material in the EXR metadata; the hidden one is not predicted.
TEST(RenderCliLayered, AutoChoosesPerMaterialAndRecordsIt) {
  TempDir dir("cli-auto");
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "ink"}});
  b.json()["materials"].push_back({{"name", "hidden"}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0)}});
  b.add_node({{"mesh", b.add_mesh({-0.5, -0.5, -0.2, 0.5, -0.5, -0.2, 0.5, 0.5, -0.2, -0.5, 0.5, -0.2}, {0, 1, 2, 0, 2, 3}, {}, 1)}});
  b.write_gltf(dir / "auto.gltf");
  std::ofstream(dir / "ink.json") << R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 100, "sigma_a": 19, "sigma_s": 1, "g": 0}]})";
  std::ofstream(dir / "map.json") << R"({"ink": "ink.json", "hidden": "ink.json"})";
  const std::string out = dir / "auto.exr";
  const Result r = run(dir, dir / "auto.gltf -o " + out + " --materials " + dir / "map.json" +
                                " --width 8 --height 8 --spp 2 --env 1 --subsurface auto --tolerance 0.05");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("material ink"), std::string::npos) << r.out;
  std::string ink, hidden, tol, ink_mode, hidden_mode;
  for (const auto& [k, v] : read_metadata(out)) {
    if (k == "lamina:auto:ink") ink = v;
    if (k == "lamina:auto:hidden") hidden = v;
    if (k == "lamina:auto_mode:ink") ink_mode = v;
    if (k == "lamina:auto_mode:hidden") hidden_mode = v;
    if (k == "lamina:tolerance") tol = v;
  }
  EXPECT_EQ(ink.rfind("chose first-order", 0), 0u) << ink;
  EXPECT_NE(hidden.find("not visible"), std::string::npos) << hidden;
  EXPECT_EQ(ink_mode, "first-order");
  EXPECT_EQ(hidden_mode, "lambert-hidden");
  EXPECT_EQ(tol, "0.05");
  for (float v : read_image(out).rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
}

// --cache: the first table-mode render builds the table and stores it, the second loads
// it (prints "0 built ... 2 loaded") and writes the same pixels; a cache path that cannot be a
// directory fails before rendering, naming it. The stack is a strongly absorbing 100 mm slab in
// air, so the table's 9 x 50000 walks are short (about a second); it is symmetric, so its
// flipped table (seen from below) is the same table: built once, loaded for the other side.
TEST(RenderCliLayered, TableCacheBuildsOnceThenLoads) {
  TempDir dir("cli-table-cache");
  write_layered_quad(dir, "ink.gltf", "ink", "ink.json",
                     R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 100, "sigma_a": 19, "sigma_s": 1, "g": 0}]})");
  const std::string common = dir / "ink.gltf" + " --materials " + dir / "map.json" +
                             " --width 6 --height 4 --spp 2 --env 1 --subsurface table --cache " + dir / "cache";
  const Result first = run(dir, common + " -o " + dir / "first.exr");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_NE(first.out.find(": 1 built in"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find(", 1 loaded"), std::string::npos) << first.out;
  const Result second = run(dir, common + " -o " + dir / "second.exr");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_NE(second.out.find(": 0 built in 0.00 s (0 by adding-doubling, 0 by the walk; 0 along texture-driven parameters), 2 loaded"),
            std::string::npos) << second.out;
  EXPECT_EQ(read_image(dir / "first.exr").rgb, read_image(dir / "second.exr").rgb);
  std::ofstream(dir / "plain") << "x";
  expect_failure(run(dir, dir / "ink.gltf --materials " + dir / "map.json" + " --subsurface table --cache " +
                              dir / "plain/cache -o " + dir / "x.exr"),
                 dir / "plain/cache", "cache directory", dir / "x.exr");
}

// A thin absorbing layer under an energy-conserving rough top (its tables, walk-built, would hold
// only the scattered light), and a smooth layer with a backward lobe (g = -0.9) that adding-
// doubling's truncated series cannot resolve, so table building falls back to the walk itself.
constexpr const char* kConservingStack =
    R"({"lamina_material": 1, "roughness": 0.4, "interface_model": "energy_conserving",
        "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 2, "sigma_s": 6, "g": 0.8}]})";
constexpr const char* kBackwardLobeStack =
    R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 0.3, "sigma_s": 6, "g": -0.9}]})";

// --table-method walk on a stack with energy-conserving rough interfaces is refused in one line
// naming the material, the reason and the alternative, before anything is built or written, in
// the table mode and in auto; the default adding-doubling tables render it.
TEST(RenderCliLayered, WalkTablesOfEnergyConservingStacksAreRefused) {
  TempDir dir("cli-ec-walk-table");
  write_layered_quad(dir, "skin.gltf", "cheek", "cheek.json", kConservingStack);
  const std::string common = dir / "skin.gltf" + " --materials " + dir / "map.json" + " --width 6 --height 4 --spp 2 --env 1";
  for (const char* mode : {"--subsurface table", "--subsurface auto --tolerance 0.05"}) {
    const Result r = run(dir, common + " " + mode + " --table-method walk -o " + dir / "x.exr");
    expect_failure(r, "cheek", "--table-method walk: material cheek", dir / "x.exr");
    EXPECT_NE(r.err.find("energy-conserving rough interfaces"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--table-method adding-doubling"), std::string::npos) << r.err;
  }
  const Result ok = run(dir, common + " --subsurface table -o " + dir / "ok.exr");
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find(" 0 by the walk;"), std::string::npos) << ok.out;
  EXPECT_EQ(ok.out.find("(0 by adding-doubling"), std::string::npos) << ok.out;
}

// The library refuses the same request (the message the CLI prints): render_job, which batch and
// the Python package call, throws RenderRequestError before rendering.
TEST(RenderCliLayered, RenderJobRefusesWalkTablesOfEnergyConservingStacks) {
  TempDir dir("lib-ec-walk-table");
  write_layered_quad(dir, "skin.gltf", "cheek", "cheek.json", kConservingStack);
  RenderRequest request;
  request.scene_path = dir / "skin.gltf";
  request.out_path = dir / "x.exr";
  request.materials_map_path = dir / "map.json";
  request.subsurface = SubsurfaceChoice::fixed(SubsurfaceMode::Table);
  request.table_method = TableSettings::Method::MonteCarlo;
  request.given = {"--subsurface", "--table-method"};
  request.settings.width = 6;
  request.settings.height = 4;
  request.settings.spp = 2;
  try {
    render_job(request);
    ADD_FAILURE() << "walk-built tables of an energy-conserving stack accepted";
  } catch (const RenderRequestError& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("material cheek"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.exr"));
}

// The walk that table building takes on its own for a lobe adding-doubling cannot resolve is
// untouched by the refusal: the default method builds that stack's table by the walk.
TEST(RenderCliLayered, TablesFallBackToTheWalkForABackwardLobe) {
  TempDir dir("cli-walk-fallback");
  write_layered_quad(dir, "ink.gltf", "ink", "ink.json", kBackwardLobeStack);
  const Result r = run(dir, dir / "ink.gltf --materials " + dir / "map.json" +
                                " --width 6 --height 4 --spp 2 --env 1 --subsurface table -o " + dir / "x.exr");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(0 by adding-doubling, "), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find(" 0 by the walk;"), std::string::npos) << r.out;
  for (float v : read_image(dir / "x.exr").rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
}

}  // namespace
}  // namespace lamina

// Hostile input: the outputs of a render are written all or none, and an image that
// does not fit in memory is refused before anything is loaded.

namespace lamina {
namespace {

// render_job writes the EXR and the PNG to temporaries and renames them together: a PNG that
// cannot be written leaves no new EXR (and the previous EXR as it was), and no temporaries.
TEST(RenderJobOutputs, AFailedPngLeavesNoNewExr) {
  TempDir dir("job-outputs");
  write_quad(dir / "quad.gltf");
  const std::string out = dir / "out.exr";
  std::ofstream(out) << "previous";
  RenderRequest request;
  request.scene_path = dir / "quad.gltf";
  request.out_path = out;
  request.png_path = dir / "no_such_dir/out.png";  // the CLI refuses this; render_job must not half-write
  request.settings.width = 4;
  request.settings.height = 4;
  request.settings.spp = 1;
  try {
    render_job(request);
    ADD_FAILURE() << "the PNG write did not fail";
  } catch (const std::exception& e) {
    // Names the PNG, not the temporary render_job wrote it to (OpenImageIO's own reason after
    // the colon may name write_png's temporary, as it always did).
    EXPECT_EQ(std::string(e.what()).rfind("cannot write '" + request.png_path + "': ", 0), 0u) << e.what();
  }
  EXPECT_EQ(slurp(out), "previous");
  for (const auto& e : std::filesystem::directory_iterator(dir.path))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << "temporary left: " << e.path();

  request.png_path = dir / "out.png";  // and both are written when both can be
  render_job(request);
  EXPECT_NO_THROW(read_image(out));
  EXPECT_NO_THROW(read_image(request.png_path));
}

// A render whose final write fails after it wrote previews leaves nothing at its outputs (the
// previews replaced what was there; an unfinished image under the output's name would pass for
// the render) and says so. The EXR's path becomes a directory while the render runs, after the
// first preview: every later write to it fails.
TEST(RenderJobOutputs, AFailureAfterPreviewsRemovesThemAndSaysSo) {
  TempDir dir("job-previews");
  write_quad(dir / "quad.gltf");
  RenderRequest request;
  request.scene_path = dir / "quad.gltf";
  request.out_path = dir / "out.exr";
  request.png_path = dir / "out.png";
  request.env = "1";
  request.settings.width = 16;
  request.settings.height = 12;
  request.settings.spp = 1 << 20;
  request.settings.time_limit = 3.0;  // bounds the render should the swap below come late
  request.settings.preview_every = 1e-6;
  std::string error;
  std::thread job([&] {
    try {
      render_job(request);
    } catch (const std::exception& e) {
      error = e.what();
    }
  });
  for (int i = 0; i < 3000 && !std::filesystem::exists(request.png_path); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const bool previewed = std::filesystem::exists(request.png_path);
  // A preview may land at the EXR's path between the remove and the create: try again until the
  // path is a directory. Nothing here throws, so the thread is always joined.
  std::error_code ec;
  for (int i = 0; i < 1000 && !std::filesystem::is_directory(request.out_path, ec); ++i) {
    std::filesystem::remove(request.out_path, ec);
    std::filesystem::create_directory(request.out_path, ec);
  }
  job.join();
  ASSERT_TRUE(previewed) << "no preview was written";
  EXPECT_NE(error.find("'" + request.out_path + "'"), std::string::npos) << error;
  EXPECT_NE(error.find("the previews written during the render were removed: nothing is left at '" + request.png_path + "'"),
            std::string::npos)
      << error;
  EXPECT_FALSE(std::filesystem::exists(request.png_path)) << "a preview was left at the output path";
  EXPECT_TRUE(std::filesystem::is_directory(request.out_path)) << "only regular files are removed";
}

// Under a 1 GB address-space limit (ulimit -v), a 16384 x 16384 image (3 GiB of floats) cannot be
// held: lamina render refuses it at once (exit 2, naming --width), instead of loading the scene
// and dying of std::bad_alloc (exit 1) as it did.
// --aovs all writes the usual channel names after R, G, B; --crop writes the region's pixels,
// equal to the same pixels of the full image, in an EXR whose data window sits in the full
// display window; --preview-every writes the outputs while rendering and the final image last.
TEST(RenderCli, AovsCropAndPreviews) {
  TempDir dir("cli-aovs");
  write_quad(dir / "quad.gltf");
  const std::string common = " --width 20 --height 14 --spp 12 --env 1 --threads 2";
  const Result full = run(dir, dir / "quad.gltf -o " + dir / "full.exr --aovs all" + common);
  ASSERT_EQ(full.exit_code, 0) << full.err;
  const ChannelImage channels = read_channels(dir / "full.exr");
  // (OpenEXR keeps channels sorted by name; readers find them by name.)
  std::vector<std::string> names = channels.names;
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"B", "G", "N.X", "N.Y", "N.Z", "R", "Z", "albedo.B", "albedo.G", "albedo.R",
                                             "variance.B", "variance.G", "variance.R"}));
  bool listed = false;
  for (const auto& [k, v] : read_metadata(dir / "full.exr")) listed |= k == "lamina:aovs" && v == "albedo,normal,depth,variance";
  EXPECT_TRUE(listed);

  const Result crop = run(dir, dir / "quad.gltf -o " + dir / "crop.exr --aovs all --crop 3,4,17,11" + common);
  ASSERT_EQ(crop.exit_code, 0) << crop.err;
  const ChannelImage part = read_channels(dir / "crop.exr");
  ASSERT_EQ(part.width, 14);
  ASSERT_EQ(part.height, 7);
  ASSERT_EQ(part.names, channels.names);
  const std::size_t nc = channels.names.size();
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 14; ++x)
      for (std::size_t c = 0; c < nc; ++c)
        ASSERT_EQ(part.values[(static_cast<std::size_t>(y) * 14 + x) * nc + c],
                  channels.values[(static_cast<std::size_t>(y + 4) * 20 + x + 3) * nc + c])
            << x << "," << y << " " << channels.names[c];
  const test::ExrWindows windows = test::read_exr_windows(dir / "crop.exr");
  EXPECT_EQ(windows.x, 3);
  EXPECT_EQ(windows.y, 4);
  EXPECT_EQ(windows.full_width, 20);
  EXPECT_EQ(windows.full_height, 14);

  // Previews after every round (rounds of 8: one preview at 8 spp), then the final image, which
  // is the one-pass image.
  const Result previewed =
      run(dir, dir / "quad.gltf -o " + dir / "prev.exr --png " + dir / "prev.png --preview-every 0.000001" + common);
  ASSERT_EQ(previewed.exit_code, 0) << previewed.err;
  const Image a = read_image(dir / "full.exr"), b = read_image(dir / "prev.exr");
  EXPECT_EQ(a.rgb, b.rgb);
  for (const auto& [k, v] : read_metadata(dir / "prev.exr")) EXPECT_NE(k, "lamina:preview") << "the final image is not a preview";

  // Bad values are one line naming the option.
  expect_failure(run(dir, dir / "quad.gltf -o " + dir / "x.exr --aovs albedo,colour" + common), "--aovs", "colour", dir / "x.exr");
  expect_failure(run(dir, dir / "quad.gltf -o " + dir / "x.exr --crop 5,5,5,9" + common), "--crop", "X0 < X1", dir / "x.exr");
  expect_failure(run(dir, dir / "quad.gltf -o " + dir / "x.exr --crop 0,0,21,9" + common), "--crop", "--width (20)", dir / "x.exr");
  expect_failure(run(dir, dir / "quad.gltf -o " + dir / "x.exr --crop 0,0,9" + common), "--crop", "4", dir / "x.exr");
  expect_failure(run(dir, dir / "quad.gltf -o " + dir / "x.exr --exposure nan" + common), "--exposure", "finite", dir / "x.exr");
  expect_failure(run(dir, dir / "quad.gltf -o " + dir / "x.exr --tone-curve aces" + common), "--tone-curve", "aces", dir / "x.exr");
}

TEST(RenderCli, AnImageThatDoesNotFitMemoryIsRefusedFirst) {
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer maps terabytes of shadow memory at start-up, which no 1 GB address-space
  // limit allows: the program cannot even start. The plain build runs this test.
  GTEST_SKIP() << "ulimit -v cannot be combined with AddressSanitizer (scripts/test.sh --sanitize)";
#endif
  TempDir dir("cli-memory");
  const std::string scene = dir / "quad.gltf", out = dir / "out.exr";
  write_quad(scene);
  const std::string err = dir / "stderr.txt";
  const std::string cmd = "ulimit -v 1000000; " + std::string(LAMINA_EXE) + " render '" + scene + "' -o '" + out +
                          "' --width 16384 --height 16384 --spp 1 --max-depth 0 >/dev/null 2>'" + err + "'";
  const int status = std::system(cmd.c_str());  // the shell of system(3): the limit ends with it
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2) << slurp(err);
  const std::string text = slurp(err);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  EXPECT_NE(text.find("--width x --height: a 16384x16384 image needs 3.00 GiB"), std::string::npos) << text;
  EXPECT_NE(text.find("RLIMIT_AS"), std::string::npos) << text;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace lamina
