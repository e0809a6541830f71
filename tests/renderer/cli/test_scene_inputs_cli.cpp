// The files a scene pulls in are inputs like the ones named on the command line (docs/contracts.md,
// "Outputs"): no output of `lamina render` or `lamina batch` may be a glTF's buffer or image, under
// any name; a batch manifest's "stack" (docs/batch.md) assigns stacks as `--stack` does; and -o
// names an EXR.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <gtest/gtest.h>

#include "renderer/image/image_io.h"
#include "tests/renderer/cli/cli_runner.h"
#include "tests/renderer/cli/exr_header.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::GltfBuilder;
using testing::TempDir;
using Result = test::CliResult;
using test::slurp;

Result run(const TempDir& dir, const std::string& args) { return test::run_lamina(dir.path, args); }

// A quad with the material "leaf", whose base colour texture is the image `image_uri` (a 2x2
// PNG written there) and whose buffer is the file `bin_name` beside the glTF.
void write_textured_quad(const TempDir& dir, const std::string& gltf, const std::string& bin_name, const std::string& image_uri) {
  Image im(2, 2);
  for (float& v : im.rgb) v = 0.5f;
  fs::create_directories((dir.path / image_uri).parent_path());
  write_png(dir / image_uri, im);
  GltfBuilder b;
  json& j = b.json();
  j["images"] = {{{"uri", image_uri}}};
  j["textures"] = {{{"source", 0}}};
  j["materials"].push_back({{"name", "leaf"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
  const int mesh = b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0);
  j["meshes"][mesh]["primitives"][0]["attributes"]["TEXCOORD_0"] = b.add_floats({0, 0, 1, 0, 1, 1, 0, 1}, 2);
  b.add_node({{"mesh", mesh}});
  b.write_gltf(dir / gltf, bin_name);
}

constexpr const char* kSmall = " --width 4 --height 4 --spp 1 --env 1 --threads 1";

// -o, --png and the previews may not be the glTF's buffer or image, by its name, another
// spelling or a symbolic link: refused with one line naming both files, before anything is
// rendered, and the file is left as it was.
TEST(SceneInputsCli, RenderOutputsThatAreTheScenesFilesAreRefused) {
  TempDir dir("scene-inputs-render");
  write_textured_quad(dir, "q.gltf", "buf.exr", "tex/leaf.png");
  fs::create_symlink(dir / "tex/leaf.png", dir / "link.png");
  const std::string bin = slurp(dir / "buf.exr"), png = slurp(dir / "tex/leaf.png");
  const Result ok = run(dir, "render " + dir / "q.gltf" + " -o " + dir / "ok.exr" + kSmall);
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  struct Case {
    std::string outputs, output, input;
  };
  const Case cases[] = {
      {"-o " + dir / "buf.exr", dir / "buf.exr", dir / "buf.exr"},
      {"-o " + dir / "x.exr --png " + dir / "tex/../tex/leaf.png", dir / "tex/../tex/leaf.png", dir / "tex/leaf.png"},
      {"-o " + dir / "x.exr --png " + dir / "link.png", dir / "link.png", dir / "tex/leaf.png"},
      {"-o " + dir / "x.exr --png " + dir / "link.png --preview-every 0.001", dir / "link.png", dir / "tex/leaf.png"},
  };
  for (const Case& c : cases) {
    const Result r = run(dir, "render " + dir / "q.gltf " + c.outputs + kSmall);
    EXPECT_EQ(r.exit_code, 1) << c.outputs << "\n" << r.err;
    EXPECT_NE(r.err.find("the output '" + c.output + "' is a file of the scene '" + dir / "q.gltf" + "' '" + c.input +
                         "': an input is never overwritten"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(slurp(dir / "buf.exr"), bin);
    EXPECT_EQ(slurp(dir / "tex/leaf.png"), png);
    EXPECT_FALSE(fs::exists(dir / "x.exr"));
  }
}

// The same for a batch: an image the scene names that is where a job's PNG would go is refused
// before any job renders (exit 2, the output, the image and the job named), and kept.
TEST(SceneInputsCli, BatchOutputsThatAreTheScenesFilesAreRefused) {
  TempDir dir("scene-inputs-batch");
  const std::string job_png = "out/jobs/q__base__default__random-walk__spp1.png";
  write_textured_quad(dir, "q.gltf", "q.bin", job_png);
  const std::string png = slurp(dir / job_png);
  std::ofstream(dir / "m.json") << json{{"lamina_batch", 1},
                                        {"settings", {{"width", 4}, {"height", 4}}},
                                        {"scenes", {{{"name", "q"}, {"file", "q.gltf"}}}},
                                        {"spp", 1}}
                                       .dump();
  const Result r = run(dir, "batch " + dir / "m.json" + " --out " + dir / "out");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("the output '" + dir / job_png + "' is a file of the scene '" + dir / "q.gltf" + "' '"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("(job q__base__default__random-walk__spp1): an input is never overwritten"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(dir / job_png), png);
  EXPECT_FALSE(fs::exists(dir / "out/jobs/q__base__default__random-walk__spp1.exr"));
}

// The variant stacks a batch writes as its record (DIR/materials/SCENE/VARIANT/) are outputs too:
// a manifest stack file there is refused, not overwritten by the variant's version.
TEST(SceneInputsCli, BatchMaterialRecordThatIsAStackFileIsRefused) {
  TempDir dir("scene-inputs-record");
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "leaf"}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0)}});
  b.write_gltf(dir / "q.gltf");
  const std::string stack = R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 20, "g": 0.3}]})";
  fs::create_directories(dir.path / "out/materials/q/thin");
  std::ofstream(dir / "out/materials/q/thin/leaf.json") << stack;
  std::ofstream(dir / "m.json") << json{{"lamina_batch", 1},
                                        {"settings", {{"width", 4}, {"height", 4}}},
                                        {"scenes", {{{"name", "q"}, {"file", "q.gltf"}, {"materials", {{"leaf", "out/materials/q/thin/leaf.json"}}}}}},
                                        {"variants", {{{"name", "thin"}, {"overrides", {{{"material", "leaf"}, {"set", {{"layers[0].thickness", 0.1}}}}}}}}},
                                        {"spp", 1}}
                                       .dump();
  const Result r = run(dir, "batch " + dir / "m.json" + " --out " + dir / "out");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("the output '" + dir / "out/materials/q/thin/leaf.json" + "' is the stack file of material 'leaf'"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(slurp(dir / "out/materials/q/thin/leaf.json"), stack);
}

std::string job_hash(const TempDir& dir, const std::string& manifest) {
  const Result r = run(dir, "batch " + dir / manifest + " --list");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.out.substr(r.out.rfind(' ') + 1);
}

const char* kStackA = R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 20, "g": 0.3}]})";
const char* kStackB = R"({"lamina_material": 1, "layers": [{"ior": 1.4, "thickness": 0.2, "sigma_a": 2.0, "sigma_s": 20, "g": 0.3}]})";

// "stack" in a manifest's settings (every scene) or a scene: FILE for every material, NAME=FILE
// for one, as `lamina render --stack` takes them. The job renders with them (the header records
// lamina:stack as the command line does), and the stack file's content is in the job's hash.
TEST(SceneInputsCli, BatchStackAssignsRecordsAndHashes) {
  TempDir dir("scene-inputs-stack");
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "leaf"}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, {}, 0)}});
  b.add_node({{"mesh", b.add_mesh({-1, -1, 1, 1, -1, 1, 1, 1, 1}, {})}});  // no material: FILE adopts it
  b.write_gltf(dir / "q.gltf");
  std::ofstream(dir / "a.json") << kStackA;
  std::ofstream(dir / "b.json") << kStackB;
  auto manifest = [&](const json& settings_stack, const json& scene_stack) {
    json m = {{"lamina_batch", 1},
              {"settings", {{"width", 4}, {"height", 4}}},
              {"scenes", {{{"name", "q"}, {"file", "q.gltf"}}}},
              {"spp", 1}};
    if (!settings_stack.is_null()) m["settings"]["stack"] = settings_stack;
    if (!scene_stack.is_null()) m["scenes"][0]["stack"] = scene_stack;
    std::ofstream(dir / "m.json") << m.dump();
  };
  manifest(nullptr, nullptr);
  const std::string plain = job_hash(dir, "m.json");
  manifest("a.json", nullptr);
  const std::string with_a = job_hash(dir, "m.json");
  EXPECT_NE(with_a, plain);
  manifest(nullptr, json::array({"leaf=a.json"}));
  const std::string named_a = job_hash(dir, "m.json");
  EXPECT_NE(named_a, with_a);  // for one material, not all
  const Result r = run(dir, "batch " + dir / "m.json" + " --out " + dir / "out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string exr = dir / "out/jobs/q__base__default__random-walk__spp1.exr";
  EXPECT_EQ(test::exr_header(exr, "lamina:stack"), "leaf=" + dir / "a.json");
  EXPECT_NE(test::exr_header(exr, "lamina:command").find("--stack leaf=" + dir / "a.json"), std::string::npos);
  EXPECT_EQ(test::exr_header(exr, "lamina:layered_materials"), "1");
  // The file's content, not its name, is hashed: a changed stack reruns the job.
  std::ofstream(dir / "a.json") << kStackB;
  EXPECT_NE(job_hash(dir, "m.json"), named_a);
  // FILE from the settings covers the mesh without a material too; the scene's NAME=FILE wins.
  manifest("a.json", "leaf=b.json");
  const Result both = run(dir, "batch " + dir / "m.json" + " --out " + dir / "out2");
  ASSERT_EQ(both.exit_code, 0) << both.err;
  const std::string exr2 = dir / "out2/jobs/q__base__default__random-walk__spp1.exr";
  EXPECT_EQ(test::exr_header(exr2, "lamina:stack"), dir / "a.json" + "; leaf=" + dir / "b.json");
  EXPECT_EQ(test::exr_header(exr2, "lamina:layered_materials"), "2");
}

// Bad assignments: the command line's reasons, at the manifest's JSON path.
TEST(SceneInputsCli, BatchStackRefusesAsTheCommandLineDoes) {
  TempDir dir("scene-inputs-stack-bad");
  GltfBuilder b;
  b.json()["materials"].push_back({{"name", "Skin"}});
  b.json()["materials"].push_back({{"name", "Lips"}});
  b.add_node({{"mesh", b.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, 0)}});
  b.write_gltf(dir / "q.gltf");
  std::ofstream(dir / "a.json") << kStackA;
  struct Case {
    json settings_stack, scene_stack, variants;
    std::string expected;
  };
  const Case cases[] = {
      {nullptr, "=a.json", nullptr, "m.json: scenes[0].stack: '=a.json': expected FILE or NAME=FILE (the material name is empty)"},
      {json::array({"a.json", "Skin="}), nullptr, nullptr,
       "m.json: settings.stack[1]: 'Skin=': expected FILE or NAME=FILE (the file is empty)"},
      {nullptr, "Skn=a.json", nullptr, "m.json: scenes[0].stack: 'Skn=a.json': no material 'Skn' in scene 'q' (its materials: 'Lips', 'Skin')"},
      {nullptr, "missing.json", nullptr, "m.json: scenes[0].stack: file '" + dir / "missing.json" + "' does not exist"},
      {nullptr, 3, nullptr, "m.json: scenes[0].stack: expected a string, got number"},
      {nullptr, json::array(), nullptr, "m.json: scenes[0].stack: expected \"FILE\", \"NAME=FILE\" or a non-empty array of them"},
      {nullptr, "Skin=a.json", json::array({{{"name", "v"}, {"overrides", {{{"material", "Skin"}, {"stack", "a.json"}}}}}}),
       "m.json: variants[0].overrides[0].material: 'Skin' is assigned a stack by \"stack\" in scene 'q'"},
  };
  for (const Case& c : cases) {
    json m = {{"lamina_batch", 1}, {"scenes", {{{"name", "q"}, {"file", "q.gltf"}}}}, {"spp", 1}};
    if (!c.settings_stack.is_null()) m["settings"] = {{"stack", c.settings_stack}};
    if (!c.scene_stack.is_null()) m["scenes"][0]["stack"] = c.scene_stack;
    if (!c.variants.is_null()) m["variants"] = c.variants;
    std::ofstream(dir / "m.json") << m.dump();
    const Result r = run(dir, "batch " + dir / "m.json" + " --list");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err << "\nexpected: " << c.expected;
  }
}

// A job EXR whose header holds a timing that is not finite (written by another program: Lamina's
// own writer refuses it) makes the summary fail, naming the file, the job and the column, and
// summary.csv is not written; before, the column was left empty without a word.
TEST(SceneInputsCli, BatchSummaryRefusesANonFiniteNumber) {
  TempDir dir("scene-inputs-csv");
  GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3})}});
  b.write_gltf(dir / "q.gltf");
  std::ofstream(dir / "m.json") << json{{"lamina_batch", 1},
                                        {"settings", {{"width", 4}, {"height", 4}}},
                                        {"scenes", {{{"name", "q"}, {"file", "q.gltf"}}}},
                                        {"lighting", {{{"name", "lit"}, {"env", 1}}}},
                                        {"spp", 1}}
                                       .dump();
  const Result first = run(dir, "batch " + dir / "m.json" + " --out " + dir / "out");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const std::string exr = dir / "out/jobs/q__base__lit__random-walk__spp1.exr";
  {
    Imf::InputFile in(exr.c_str());
    Imf::Header header = in.header();
    header.insert("lamina:seconds", Imf::StringAttribute("inf"));
    const Imath::Box2i dw = header.dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    std::vector<float> pixels(static_cast<std::size_t>(w) * h * 3);
    Imf::FrameBuffer frame;
    for (int c = 0; c < 3; ++c)
      frame.insert(c == 0 ? "R" : c == 1 ? "G" : "B",
                   Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data() + c), 3 * sizeof(float), 3 * sizeof(float) * w));
    in.setFrameBuffer(frame);
    in.readPixels(dw.min.y, dw.max.y);
    Imf::Header out_header(header);
    out_header.channels() = Imf::ChannelList();
    for (const char* c : {"R", "G", "B"}) out_header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    const std::string tmp = dir / "tmp.exr";
    {
      Imf::OutputFile out(tmp.c_str(), out_header);
      out.setFrameBuffer(frame);
      out.writePixels(h);
    }
    fs::rename(tmp, exr);
  }
  fs::remove(dir / "out/summary.csv");
  const Result r = run(dir, "batch " + dir / "m.json" + " --out " + dir / "out" + " --finalize");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(dir / "out/summary.csv" + ": q__base__lit__random-walk__spp1 seconds is not finite (inf)"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "out/summary.csv"));
}

// -o x.png is refused (the render, its previews and lamina batch write the EXR at -o), and the
// message gives the command that writes the display PNG there.
TEST(SceneInputsCli, OutPngSaysToUsePng) {
  TempDir dir("scene-inputs-out-png");
  write_textured_quad(dir, "q.gltf", "q.bin", "t.png");
  const Result r = run(dir, "render " + dir / "q.gltf" + " -o " + dir / "view.png" + kSmall);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("use --png '" + dir / "view.png" + "' for the display PNG"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("-o '" + dir / "view.exr" + "' --png '" + dir / "view.png" + "'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "view.png"));
}

}  // namespace
}  // namespace lamina
