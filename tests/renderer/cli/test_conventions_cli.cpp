// The conventions a user expects of `lamina render` and `lamina --version` (docs/rendering.md,
// docs/outputs.md): progress and summaries that tell the truth, outputs chosen by their name,
// the version naming the build.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>

#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <gtest/gtest.h>

#include "renderer/image/image_io.h"
#include "renderer/layered/material_binding.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/util/version.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using testing::GltfBuilder;
using testing::TempDir;
using Result = test::CliResult;

Result run(const TempDir& dir, const std::string& args) { return test::run_lamina(dir.path, args); }

void write_quad(const std::string& path) {
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3})}});
  b.write_gltf(path);
}

// Seconds of a duration as Progress prints it: "4.2s", "3m02s", "1h05m".
double seconds_of(const std::string& text) {
  std::smatch m;
  if (std::regex_match(text, m, std::regex(R"(([0-9.]+)s)"))) return std::stod(m[1]);
  if (std::regex_match(text, m, std::regex(R"(([0-9]+)m([0-9]+)s)"))) return 60.0 * std::stod(m[1]) + std::stod(m[2]);
  if (std::regex_match(text, m, std::regex(R"(([0-9]+)h([0-9]+)m)"))) return 3600.0 * std::stod(m[1]) + 60.0 * std::stod(m[2]);
  ADD_FAILURE() << "not a duration: " << text;
  return 0.0;
}

// A render under --time-limit whose --spp alone would take hours: every progress line's
// elapsed time plus its ETA stays within the limit (plus the time to finish the tiles in
// flight), and the summary gives the samples taken, not the --spp ceiling. The log prints a line
// every 5 s, so the limit is a little above that.
TEST(ConventionsCli, TimeLimitedProgressAndSummaryTellTheTruth) {
  TempDir dir("conv-eta");
  write_quad(dir / "quad.gltf");
  constexpr double kLimit = 5.5;
  const Result r = run(dir, "render " + dir / "quad.gltf" + " -o " + dir / "q.exr" +
                                " --width 8 --height 8 --spp 1048576 --env 1 --threads 1 --time-limit 5.5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::regex line(R"(render: [0-9.]+% \(([0-9.hms]+) elapsed, ETA ([0-9.hms?]+)\))");
  int lines = 0;
  for (std::sregex_iterator it(r.err.begin(), r.err.end(), line), end; it != end; ++it, ++lines) {
    const double elapsed = seconds_of((*it)[1]), eta = seconds_of((*it)[2]);
    EXPECT_LE(eta, kLimit) << it->str();
    EXPECT_LE(elapsed + eta, kLimit + 0.2) << it->str();  // the print rounds to 0.1 s
  }
  EXPECT_GE(lines, 1) << r.err;
  EXPECT_EQ(r.out.find("1048576 spp"), std::string::npos) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(8x8, mean [0-9.]+ spp)"))) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(samples per pixel: mean [0-9.]+ \(min [0-9]+, max [0-9]+\))"))) << r.out;
}

// The EXR says its colour space in the standard attribute: linear Rec. 709 primaries, D65 white.
TEST(ConventionsCli, ExrCarriesRec709Chromaticities) {
  TempDir dir("conv-chroma");
  write_quad(dir / "quad.gltf");
  const Result r = run(dir, "render " + dir / "quad.gltf" + " -o " + dir / "q.exr" + " --width 4 --height 4 --spp 1 --env 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  Imf::InputFile file((dir / "q.exr").c_str());
  ASSERT_TRUE(Imf::hasChromaticities(file.header()));
  const Imf::Chromaticities& c = Imf::chromaticities(file.header());
  EXPECT_EQ(c.red, Imath::V2f(0.64f, 0.33f));
  EXPECT_EQ(c.green, Imath::V2f(0.30f, 0.60f));
  EXPECT_EQ(c.blue, Imath::V2f(0.15f, 0.06f));
  EXPECT_EQ(c.white, Imath::V2f(0.3127f, 0.3290f));
}

// -o's extension chooses the format; the render writes OpenEXR, so any other name is refused
// with one line naming the argument (and nothing is written), before the scene is read.
TEST(ConventionsCli, OutputExtensionOtherThanExrIsRefused) {
  TempDir dir("conv-ext");
  write_quad(dir / "quad.gltf");
  for (const std::string name : {"q.png", "q.tif", "q", "q.exr.txt"}) {
    const Result r = run(dir, "render " + dir / "quad.gltf" + " -o " + dir / name + " --width 4 --height 4 --spp 1");
    EXPECT_EQ(r.exit_code, 2) << name;
    EXPECT_NE(r.err.find("--out '" + dir / name + "'"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--png"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / name)) << name;
  }
  const Result upper = run(dir, "render " + dir / "quad.gltf" + " -o " + dir / "Q.EXR" + " --width 4 --height 4 --spp 1");
  EXPECT_EQ(upper.exit_code, 0) << upper.err;
}

// A render reads an emissive texture through TEXCOORD_1 when the textureInfo says texCoord 1:
// the quad's TEXCOORD_0 points at the texture's red half, TEXCOORD_1 at its green half, and the
// camera sees green (before, set 0 was read whatever texCoord said).
TEST(ConventionsCli, EmissiveTextureReadsTexCoord1) {
  TempDir dir("conv-texcoord1");
  Image im(2, 1);
  im.pixel(0, 0)[0] = 1.0f;
  im.pixel(1, 0)[1] = 1.0f;
  write_png(dir / "tex.png", im);
  GltfBuilder b;
  nlohmann::json& j = b.json();
  j["images"] = {{{"uri", "tex.png"}}};
  j["samplers"] = {{{"wrapS", 33071}, {"wrapT", 33071}}};
  j["textures"] = {{{"source", 0}, {"sampler", 0}}};
  j["materials"].push_back({{"name", "glow"},
                            {"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}}},
                            {"emissiveFactor", {1.0, 1.0, 1.0}},
                            {"emissiveTexture", {{"index", 0}, {"texCoord", 1}}}});
  const int mesh = b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0);
  nlohmann::json& attributes = j["meshes"][mesh]["primitives"][0]["attributes"];
  attributes["TEXCOORD_0"] = b.add_floats({0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f}, 2);
  attributes["TEXCOORD_1"] = b.add_floats({0.75f, 0.5f, 0.75f, 0.5f, 0.75f, 0.5f, 0.75f, 0.5f}, 2);
  b.add_node({{"mesh", mesh}});
  b.write_gltf(dir / "glow.gltf");
  const Result r = run(dir, "render " + dir / "glow.gltf" + " -o " + dir / "g.exr" + " --width 8 --height 8 --spp 1 --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image out = read_image(dir / "g.exr");
  EXPECT_NEAR(out.pixel(4, 4)[0], 0.0, 1e-6);
  EXPECT_NEAR(out.pixel(4, 4)[1], 1.0, 1e-5);
}

// --stack: NAME=FILE wins over FILE, which wins over the map and the extras, and FILE reaches
// meshes without a material (they get the material "(no material)"); the sources say which.
TEST(ConventionsCli, StackAssignmentsBindByPrecedence) {
  TempDir dir("conv-stack-bind");
  const std::string source = LAMINA_SOURCE_DIR;
  const std::string skin = source + "/scenes/materials/skin.json", leaf = source + "/scenes/materials/leaf.json";
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "a"}, {"extras", {{"lamina", {{"stack", leaf}}}}}});
  b.json()["materials"].push_back({{"name", "b"}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 1, 1, 0, 1, 0, 1, 1}, {}, {}, 1)}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 2, 1, 0, 2, 0, 1, 2})}});  // no material
  b.write_gltf(dir / "s.gltf");
  SceneDesc desc = load_gltf(dir / "s.gltf");
  const std::vector<StackAssignment> stacks = {{"", skin}, {"b", leaf}};
  adopt_meshes_without_material(stacks, &desc);
  ASSERT_EQ(desc.materials.size(), 3u);
  EXPECT_EQ(desc.materials[2].name, kNoMaterialName);
  EXPECT_EQ(desc.meshes[2].material, 2);
  const LayeredBindings bound = bind_layered_materials(desc, "", {}, stacks);
  ASSERT_EQ(bound.count(), 3);
  EXPECT_EQ(bound.by_material[0]->source(), skin);  // FILE over the extras
  EXPECT_EQ(bound.by_material[1]->source(), leaf);  // NAME=FILE over FILE
  EXPECT_EQ(bound.by_material[2]->source(), skin);  // the mesh without a material
  // Without --stack: the extras bind "a" only, and no material is added.
  SceneDesc plain = load_gltf(dir / "s.gltf");
  adopt_meshes_without_material({}, &plain);
  EXPECT_EQ(plain.materials.size(), 2u);
  EXPECT_EQ(bind_layered_materials(plain, "").count(), 1);
}

// On the command line: the header records --stack; an unknown name is one line listing the
// scene's materials; a malformed argument is a usage error naming it.
TEST(ConventionsCli, StackOptionRendersRecordsAndRefuses) {
  TempDir dir("conv-stack-cli");
  write_quad(dir / "quad.gltf");  // one mesh, no material
  const std::string skin = std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json";
  const Result r = run(dir, "render " + dir / "quad.gltf" + " -o " + dir / "q.exr" + " --stack " + skin +
                                " --width 4 --height 4 --spp 1 --env 1 --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("1 material(s)"), std::string::npos) << r.out;
  std::string recorded;
  for (const auto& [k, v] : read_metadata(dir / "q.exr"))
    if (k == "lamina:stack") recorded = v;
  EXPECT_EQ(recorded, skin);
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "Skin"}});
  b.json()["materials"].push_back({{"name", "Lips"}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
  b.write_gltf(dir / "two.gltf");
  const Result unknown = run(dir, "render " + dir / "two.gltf" + " -o " + dir / "u.exr" + " --stack Skn=" + skin);
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_NE(unknown.err.find("--stack 'Skn=" + skin + "': no material 'Skn'"), std::string::npos) << unknown.err;
  EXPECT_NE(unknown.err.find("'Skin', 'Lips'"), std::string::npos) << unknown.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "u.exr"));
  const Result bad = run(dir, "render " + dir / "two.gltf" + " -o " + dir / "u.exr" + " --stack =" + skin);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--stack '=" + skin + "'"), std::string::npos) << bad.err;
}

// `lamina --version` names the release and the commit (git describe of the sources, when they
// are a git checkout: then the commit exists in it), while every hash takes the release alone.
TEST(ConventionsCli, VersionNamesTheCommitButHashesTakeTheReleaseOnly) {
  TempDir dir("conv-version");
  const Result r = run(dir, "--version");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_match(r.out, m, std::regex(R"(lamina ([0-9]+\.[0-9]+\.[0-9]+) \(commit ([^ )]+)\)\n)"))) << r.out;
  EXPECT_EQ(m[1].str(), lamina_version());
  EXPECT_EQ(m[2].str(), lamina_commit());
  EXPECT_TRUE(std::regex_match(std::string(lamina_version()), std::regex(R"([0-9]+\.[0-9]+\.[0-9]+)")));
  const std::string source = LAMINA_SOURCE_DIR;
  const bool git = std::system(("git -C '" + source + "' rev-parse --show-toplevel >/dev/null 2>&1").c_str()) == 0;
  if (!git) {
    EXPECT_EQ(m[2].str(), "unknown");
    return;
  }
  // describe gives TAG-N-gHASH, or HASH without tags, with -dirty for uncommitted changes.
  std::string commit = std::regex_replace(m[2].str(), std::regex("-dirty$"), "");
  commit = std::regex_replace(commit, std::regex("^.*-g([0-9a-f]+)$"), "$1");
  EXPECT_EQ(std::system(("git -C '" + source + "' cat-file -e '" + commit + "^{commit}' 2>/dev/null").c_str()), 0)
      << commit << " is not a commit of " << source;
}

}  // namespace
}  // namespace lamina
