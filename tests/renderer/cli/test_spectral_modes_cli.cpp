// The spectral mode wherever a render is asked for (docs/batch.md, docs/spectral.md): a batch
// manifest's "spectral" (settings and per scene) renders the image `lamina render --spectral`
// renders, bit for bit, with the same header key; it enters a job's hash only when set, so a
// manifest without it keeps its hashes; a bad value is one line at its JSON path; a combination
// the command line refuses is refused by the batch in the same words.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "renderer/image/image_io.h"
#include "tests/renderer/batch_fixture.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/cli/exr_header.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using nlohmann::json;
using testing::TempDir;
using Result = test::CliResult;

Result run(const TempDir& dir, const std::string& args) { return test::run_lamina(dir.path, args); }

// The quad with a layered "skin" (the fixture's two-layer stack) under a white sky.
struct SpectralBatch {
  TempDir dir;
  explicit SpectralBatch(const std::string& name) : dir(name) {
    testing::write_batch_quad(dir / "q.gltf");
    testing::write_json(dir / "s.json", testing::small_stack());
  }
  json manifest(const json& settings_spectral, const json& scene_spectral, const std::string& mode = "random-walk") const {
    json m = {{"lamina_batch", 1},
              {"settings", {{"width", 8}, {"height", 6}, {"seed", 3}, {"max_depth", 8}, {"stack", "s.json"}}},
              {"scenes", {{{"name", "q"}, {"file", "q.gltf"}}}},
              {"lighting", {{{"name", "sky"}, {"env", 1.0}}}},
              {"modes", {mode}},
              {"spp", {2}}};
    if (!settings_spectral.is_null()) m["settings"]["spectral"] = settings_spectral;
    if (!scene_spectral.is_null()) m["scenes"][0]["spectral"] = scene_spectral;
    return m;
  }
  Result batch(const json& m, const std::string& args) const {
    testing::write_json(dir / "m.json", m);
    return run(dir, "batch " + dir / "m.json" + " " + args);
  }
  std::string hash(const json& m) const {
    const Result r = batch(m, "--list");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out.substr(r.out.rfind(' ') + 1);
  }
  // `lamina render` with the job's settings.
  Result render(const std::string& out, const std::string& extra) const {
    return run(dir, "render " + dir / "q.gltf" + " --width 8 --height 6 --spp 2 --seed 3 --max-depth 8 --env 1 --stack " +
                        dir / "s.json" + " -o " + out + " " + extra);
  }
};

// Every channel's values (RGB and the sample counts).
std::vector<float> pixels(const ChannelImage& im) { return im.values; }

TEST(SpectralModesCli, BatchSpectralRendersWhatTheCommandLineRenders) {
  SpectralBatch b("spectral-batch-image");
  const Result r = b.batch(b.manifest(true, nullptr), "--out " + b.dir / "out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string job = b.dir / "out/jobs/q__base__sky__random-walk__spp2.exr";
  const Result cli = b.render(b.dir / "cli.exr", "--spectral");
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  const Result cli_rgb = b.render(b.dir / "rgb.exr", "");
  ASSERT_EQ(cli_rgb.exit_code, 0) << cli_rgb.err;
  const ChannelImage batch_image = read_channels(job), spectral = read_channels(b.dir / "cli.exr"),
                     plain = read_channels(b.dir / "rgb.exr");
  EXPECT_EQ(pixels(batch_image), pixels(spectral));  // bit for bit
  EXPECT_NE(pixels(batch_image), pixels(plain));     // and not the RGB mode's image
  EXPECT_EQ(test::exr_header(job, "lamina:spectral"), test::exr_header(b.dir / "cli.exr", "lamina:spectral"));
  EXPECT_NE(test::exr_header(job, "lamina:spectral"), "");
  EXPECT_NE(test::exr_header(job, "lamina:command").find(" --spectral"), std::string::npos) << test::exr_header(job, "lamina:command");
  // The scene's own "spectral": false wins over the settings': the RGB image.
  const Result off = b.batch(b.manifest(true, false), "--out " + b.dir / "out_off");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  const std::string off_job = b.dir / "out_off/jobs/q__base__sky__random-walk__spp2.exr";
  EXPECT_EQ(pixels(read_channels(off_job)), pixels(plain));
  EXPECT_EQ(test::exr_header(off_job, "lamina:spectral"), "");
}

// "spectral" enters the hash only when true: a manifest without it, or with false, keeps the
// hash it had; true in the settings or the scene changes it alike.
TEST(SpectralModesCli, HashChangesOnlyWhenSpectral) {
  SpectralBatch b("spectral-batch-hash");
  const std::string plain = b.hash(b.manifest(nullptr, nullptr));
  EXPECT_EQ(b.hash(b.manifest(false, nullptr)), plain);
  EXPECT_EQ(b.hash(b.manifest(nullptr, false)), plain);
  EXPECT_EQ(b.hash(b.manifest(true, false)), plain);
  const std::string spectral = b.hash(b.manifest(true, nullptr));
  EXPECT_NE(spectral, plain);
  EXPECT_EQ(b.hash(b.manifest(nullptr, true)), spectral);
  EXPECT_EQ(b.hash(b.manifest(false, true)), spectral);
}

// A skin by chromophores whose melanin a map sets (docs/stack_bindings.md), on a quad with UVs.
void write_melanin_mapped_quad(const TempDir& dir, const std::string& gltf) {
  std::ofstream(dir / "c.json") << R"({"lamina_material": 1, "layers": [
      {"ior": 1.4, "thickness": 0.1, "chromophores": {"melanin": 0.05, "baseline": 0.5,
       "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}},
      {"ior": 1.4, "thickness": "inf", "chromophores": {"blood": 0.02, "water": 0.6, "baseline": 0.38,
       "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}}]})";
  Image map(2, 2);
  for (float& v : map.rgb) v = 0.5f;
  write_png(dir / "melanin.png", map);
  testing::GltfBuilder b;
  nlohmann::json& j = b.json();
  j["materials"].push_back({{"name", "skin"},
                            {"extras",
                             {{"lamina",
                               {{"stack", "c.json"},
                                {"bind", {{{"parameter", "layers[0].chromophores.melanin"}, {"texture", "melanin.png"},
                                           {"channel", "r"}, {"range", {0.01, 0.3}}}}}}}}}});
  const int mesh = b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0);
  j["meshes"][mesh]["primitives"][0]["attributes"]["TEXCOORD_0"] = b.add_floats({0, 0, 1, 0, 1, 1, 0, 1}, 2);
  b.add_node({{"mesh", mesh}});
  b.write_gltf(dir / gltf);
}

TEST(SpectralModesCli, BadValuesAndRefusalsAreTheCommandLines) {
  SpectralBatch b("spectral-batch-bad");
  const Result word = b.batch(b.manifest("yes", nullptr), "--list");
  EXPECT_EQ(word.exit_code, 2);
  EXPECT_NE(word.err.find("m.json: settings.spectral: expected true or false, got \"yes\""), std::string::npos) << word.err;
  const Result number = b.batch(b.manifest(nullptr, 1), "--list");
  EXPECT_EQ(number.exit_code, 2);
  EXPECT_NE(number.err.find("m.json: scenes[0].spectral: expected true or false, got 1"), std::string::npos) << number.err;
  // What the spectral mode refuses (chromophores bound to a map in the table mode,
  // renderer/layered/spectral_tables.h): the batch's job fails with the command line's line.
  write_melanin_mapped_quad(b.dir, "m.gltf");
  const Result cli = run(b.dir, "render " + b.dir / "m.gltf" + " --width 8 --height 6 --spp 2 --seed 3 --max-depth 8 --env 1 "
                                "--spectral --subsurface table -o " + b.dir / "x.exr");
  EXPECT_EQ(cli.exit_code, 1);
  const std::string line = cli.err.substr(cli.err.rfind("lamina render: "));
  EXPECT_NE(line.find("chromophore layers bound to maps are not tabulated per wavelength"), std::string::npos) << line;
  json m = b.manifest(true, nullptr, "table");
  m["settings"].erase("stack");
  m["scenes"][0]["file"] = "m.gltf";
  const Result r = b.batch(m, "--out " + b.dir / "out");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(line), std::string::npos) << r.err << "\nexpected: " << line;
  EXPECT_FALSE(std::filesystem::exists(b.dir / "x.exr"));
  // auto renders such a material by the walk instead, and says so.
  const Result a = run(b.dir, "render " + b.dir / "m.gltf" + " --width 8 --height 6 --spp 1 --env 1 --spectral --subsurface auto "
                              "--tolerance 0.5 -o " + b.dir / "a.exr");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  EXPECT_EQ(test::exr_header(b.dir / "a.exr", "lamina:auto_mode:skin"), "random-walk");
}

}  // namespace
}  // namespace lamina
