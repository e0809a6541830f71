// `lamina fit` end to end: the measurements come from `lamina brdf --method adding-doubling`'s
// totals of a known slab (the other command as the data source), the fit from another start
// recovers the slab and writes a material file that `lamina brdf` reads back to the same totals;
// the unidentifiable g is reported on stderr; bad input is a one-line error with a non-zero exit.
// The albedo-texture mode: a texture made from known fractions comes back as maps of them.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/tables/albedo.h"
#include "materials/stack/stack_file.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/stack_bindings.h"
#include "tests/renderer/cli/cli_runner.h"

namespace {

using lamina::test::CliResult;
using lamina::test::slurp;

const char* kTruth = R"({ "lamina_material": 1, "layers": [ { "ior": 1.4, "thickness": 0.5,
  "sigma_a": [0.5, 1.0, 2.0], "sigma_s": [8.0, 10.0, 12.0], "g": 0.8 } ], "below": { "ior": 1.0 } })";
const char* kStart = R"({ "lamina_material": 1, "layers": [ { "ior": 1.4, "thickness": 0.5,
  "sigma_a": 1.0, "sigma_s": 20.0, "g": 0.8 } ], "below": { "ior": 1.0 } })";

class CliFit : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/lamina_cli_fit_XXXXXX";
    dir_ = mkdtemp(tmpl);
    std::ofstream(dir_ + "/truth.json") << kTruth;
    std::ofstream(dir_ + "/start.json") << kStart;
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }
  CliResult run(const std::string& args) { return lamina::test::run_lamina(dir_, args); }
  void expect_one_line_error(const std::string& args, const std::string& must_contain) {
    const CliResult r = run(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(must_contain), std::string::npos) << args << ": " << r.err;
  }
  // R and T at normal incidence of `stack` by lamina brdf, as rows of the measurement CSV.
  std::string measured_rows(const std::string& stack, double sigma) {
    const CliResult r = run("brdf " + stack + " --theta-i 0 --method adding-doubling --summary " + dir_ + "/totals.json");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(dir_ + "/totals.json"));
    std::string rows;
    static const char* kCh[] = {"r", "g", "b"};
    for (int c = 0; c < 3; ++c) {
      const double R = j["R_specular"][c].get<double>() + j["R_diffuse"][c].get<double>();
      const double T = j["T_ballistic"][c].get<double>() + j["T_diffuse"][c].get<double>();
      rows += std::string("R,") + kCh[c] + ",0," + std::to_string(R) + "," + std::to_string(sigma) + "\n";
      rows += std::string("T,") + kCh[c] + ",0," + std::to_string(T) + "," + std::to_string(sigma) + "\n";
    }
    return rows;
  }
  std::string dir_;
};

const std::string kHeader = "quantity,channel,theta_i_deg,value,sigma\n";

// The fit at the quadrature of the data (lamina brdf's default, 16 points), so that the file read
// back gives the report's model values to the CSV's rounding.
TEST_F(CliFit, RecoversASlabAndWritesAFileThatReadsBack) {
  std::ofstream(dir_ + "/m.csv") << kHeader << measured_rows(dir_ + "/truth.json", 1e-4);
  const CliResult r = run("fit " + dir_ + "/start.json --data " + dir_ + "/m.csv --param 'layers[0].sigma_a=0:10'" +
                          " --param 'layers[0].sigma_s=0:100' --quadrature-points 16 --out " + dir_ + "/fitted.json --summary " + dir_ +
                          "/fit.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const nlohmann::json fit = nlohmann::json::parse(slurp(dir_ + "/fit.json"));
  ASSERT_EQ(fit["parameters"].size(), 6u);
  const double sa[] = {0.5, 1.0, 2.0}, ss[] = {8.0, 10.0, 12.0};
  for (int c = 0; c < 3; ++c) {
    // The data are rounded to 6 decimals by std::to_string (error <= 5e-7 << sigma 1e-4): the
    // recovered values lie within 3 of their sigmas of the truth.
    const nlohmann::json& a = fit["parameters"][c];
    const nlohmann::json& s = fit["parameters"][3 + c];
    EXPECT_NEAR(a["value"].get<double>(), sa[c], 3 * a["sigma"].get<double>()) << a.dump();
    EXPECT_NEAR(s["value"].get<double>(), ss[c], 3 * s["sigma"].get<double>()) << s.dump();
  }
  EXPECT_EQ(fit["dof"], 0);
  // The fitted file is a material file whose totals are the model's values in the report.
  const std::string rows = measured_rows(dir_ + "/fitted.json", 1e-4);
  for (const nlohmann::json& m : fit["measurements"]) {
    const std::string key = m["quantity"].get<std::string>() + "," + m["channel"].get<std::string>() + ",0,";
    const std::size_t at = rows.find(key);
    ASSERT_NE(at, std::string::npos);
    EXPECT_NEAR(std::stod(rows.substr(at + key.size())), m["model"].get<double>(), 1e-6);
  }
}

TEST_F(CliFit, UnidentifiedGIsAWarningLine) {
  std::ofstream(dir_ + "/m.csv") << kHeader << measured_rows(dir_ + "/truth.json", 1e-3);
  const CliResult r = run("fit " + dir_ + "/start.json --data " + dir_ + "/m.csv --param 'layers[0].sigma_a=0:10'" +
                          " --param 'layers[0].sigma_s=0:100' --param 'layers[0].g=0:0.95' --summary " + dir_ + "/fit.json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("lamina fit: warning: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("layers[0].g[r]"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not identified"), std::string::npos) << r.err;
  const nlohmann::json fit = nlohmann::json::parse(slurp(dir_ + "/fit.json"));
  EXPECT_FALSE(fit["warnings"].empty());
}

// A BRDF/BTDF table as the measurements: lamina brdf's own table (adding-doubling, 6 x 12 bins,
// 30 degrees) of the slab, fitted from another start for sigma_a, sigma_s and g per channel. The
// table's stderr is 0, so --table-sigma sets the bins' sigma; the data are the model itself to
// 9 digits, so every value comes back within a small fraction of its sigma (0.03: the stopping
// rule's ~1e-3 sigma plus the CSV's rounding), and g, which R and T alone cannot give (the test
// above), has a finite sigma.
TEST_F(CliFit, BrdfTableAsMeasurementsRecoversTheSlab) {
  const CliResult b = run("brdf " + dir_ + "/truth.json --theta-i 30 --method adding-doubling --bins-theta 6 --bins-phi 12 --out " +
                          dir_ + "/t30.csv --summary " + dir_ + "/t30.json");
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const CliResult r = run("fit " + dir_ + "/start.json --table 30:" + dir_ + "/t30.csv --table-sigma 0.001" +
                          " --param 'layers[0].sigma_a=0:10' --param 'layers[0].sigma_s=0:100' --param 'layers[0].g=0:0.95'" +
                          " --summary " + dir_ + "/fit.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const nlohmann::json fit = nlohmann::json::parse(slurp(dir_ + "/fit.json"));
  ASSERT_EQ(fit["parameters"].size(), 9u);
  const double truth[3][3] = {{0.5, 1.0, 2.0}, {8.0, 10.0, 12.0}, {0.8, 0.8, 0.8}};
  for (int p = 0; p < 3; ++p)
    for (int c = 0; c < 3; ++c) {
      const nlohmann::json& x = fit["parameters"][3 * p + c];
      ASSERT_FALSE(x["sigma"].is_null()) << x.dump();
      EXPECT_NEAR(x["value"].get<double>(), truth[p][c], 0.03 * x["sigma"].get<double>()) << x.dump();
    }
  EXPECT_EQ(fit["measurements"].size(), 2u * 6 * 12 * 3);
  EXPECT_EQ(fit["measurements"][0]["quantity"], "bin");
  EXPECT_EQ(fit["measurements"][0]["side"], "reflect");
  // Usage: a --table without its angle, or no measurements at all.
  const CliResult u = run("fit " + dir_ + "/start.json --table " + dir_ + "/t30.csv --param 'layers[0].sigma_a=0:10'");
  EXPECT_EQ(u.exit_code, 2) << u.err;
  EXPECT_NE(u.err.find("expected DEG:TABLE.csv"), std::string::npos) << u.err;
  const CliResult none = run("fit " + dir_ + "/start.json --param 'layers[0].sigma_a=0:10'");
  EXPECT_EQ(none.exit_code, 2) << none.err;
  EXPECT_NE(none.err.find("no measurements: give --data and/or --table"), std::string::npos) << none.err;
}

TEST_F(CliFit, BadInputIsOneLineError) {
  std::ofstream(dir_ + "/m.csv") << kHeader << "R,r,0,0.3,0.01\nT,r,0,0.4,0.01\n";
  std::ofstream(dir_ + "/nocol.csv") << "quantity,channel,value,sigma\nR,r,0.3,0.01\n";
  std::ofstream(dir_ + "/nan.csv") << kHeader << "R,r,0,nan,0.01\n";
  const std::string fit = "fit " + dir_ + "/start.json ";
  expect_one_line_error(fit + "--data " + dir_ + "/m.csv --param 'layers[2].sigma_a=0:1'",
                        "start.json: layers[2].sigma_a: the stack has 1 layer(s)");
  expect_one_line_error(fit + "--data " + dir_ + "/m.csv --param 'layers[0].sigma_a=5:1'",
                        "layers[0].sigma_a: the lower bound 5 is not below the upper bound 1");
  expect_one_line_error(fit + "--data " + dir_ + "/m.csv --param 'layers[0].sigma_a'", "expected PATH=LO:HI");
  expect_one_line_error(fit + "--data " + dir_ + "/m.csv --param 'layers[0].sigma_a=0:nan'", "--param");
  expect_one_line_error(fit + "--data " + dir_ + "/nocol.csv --param 'layers[0].sigma_a=0:1'",
                        "nocol.csv: line 1: missing column 'theta_i_deg'");
  expect_one_line_error(fit + "--data " + dir_ + "/nan.csv --param 'layers[0].sigma_a=0:1'", "nan.csv: line 2: value 'nan' is not a finite decimal number");
  expect_one_line_error(fit + "--data " + dir_ + "/absent.csv --param 'layers[0].sigma_a=0:1'", "absent.csv: cannot read the measurements: does not exist");
  expect_one_line_error("fit " + dir_ + "/absent.json --data " + dir_ + "/m.csv --param 'layers[0].sigma_a=0:1'", "absent.json");
}

// --- lamina fit --albedo-texture ---------------------------------------------------------------

const std::string kSkin = std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json";
const std::string kMelanin = "layers[0].components[0].fraction", kBlood = "layers[1].components[0].fraction";
const std::string kAxes = " --param '" + kMelanin + "=0:0.3' --param '" + kBlood + "=0:0.2'";
constexpr int kW = 12, kH = 8;

class CliFitAlbedo : public CliFit {
 protected:
  void SetUp() override {
    CliFit::SetUp();
    std::filesystem::create_directory(dir_ + "/out");
    // The texture: melanin along x and blood along y, 5% to 95% of their ranges (the lookup's
    // stated error is for the inside), each texel the skin's diffuse albedo (R_h - R_hs at 8
    // points: the mode's defaults) at its fractions.
    const lamina::StackTemplate t = lamina::load_stack_template(kSkin);
    const std::vector<lamina::StackParameter> ps = {lamina::parse_stack_parameter(t, kMelanin),
                                                    lamina::parse_stack_parameter(t, kBlood)};
    albedo_ = lamina::Image(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const double u0 = 0.05 + 0.9 * x / (kW - 1), u1 = 0.05 + 0.9 * y / (kH - 1);
        truth_[0][y * kW + x] = u0, truth_[1][y * kW + x] = u1;
        const lamina::Spectrum v[2] = {lamina::Spectrum(0.3 * u0), lamina::Spectrum(0.2 * u1)};
        lamina::LayerStack s;
        lamina::apply_parameters(t, ps, v, &s);
        const lamina::Spectrum a = lamina::diffuse_bihemispherical_albedo_adding_doubling(s, lamina::AddingDoublingSettings{8});
        for (int c = 0; c < 3; ++c) albedo_.pixel(x, y)[c] = static_cast<float>(a[c]);
      }
    lamina::write_exr(dir_ + "/albedo.exr", albedo_);
  }
  std::string fit_albedo(const std::string& texture, const std::string& more = "") {
    return "fit " + kSkin + " --albedo-texture " + dir_ + "/" + texture + kAxes + " --out-dir " + dir_ + "/out" + more;
  }
  // The largest |map - truth| over the texels, in units of the range (the maps store t).
  double worst_map_error() {
    double worst = 0.0;
    for (int a = 0; a < 2; ++a) {
      const lamina::ParameterMap m =
          lamina::read_parameter_map(dir_ + "/out/" + (a == 0 ? "layers0.components0.fraction.png" : "layers1.components0.fraction.png"));
      EXPECT_EQ(m.width, kW);
      EXPECT_EQ(m.height, kH);
      for (int i = 0; i < kW * kH; ++i) worst = std::max(worst, std::abs(m.values[i * m.channels] - truth_[a][i]));
    }
    return worst;
  }
  bool out_is_empty() { return std::filesystem::is_empty(dir_ + "/out"); }
  lamina::Image albedo_;
  double truth_[2][kW * kH];
};

// The lookup's stated error at 33 nodes on this grid (materials/fit/albedo_lookup.h): 1.3% of the
// range, Delta E 0.14. The maps are 16-bit (1.5e-5 of the range), so the fractions read back
// through the texture bindings' own reader must lie within 2% of the range.
TEST_F(CliFitAlbedo, LinearTextureOfKnownFractionsComesBack) {
  const CliResult r = run(fit_albedo("albedo.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("lamina fit: 12 x 8 texels (linear, diffuse albedo)"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("fit: 100%"), std::string::npos) << r.err;  // the progress's closing line
  const double worst = worst_map_error();
  std::printf("worst map error %.5f of the range\n", worst);
  EXPECT_LT(worst, 0.02);
  const nlohmann::json rep = nlohmann::json::parse(slurp(dir_ + "/out/albedo_fit.json"));
  EXPECT_EQ(rep["texture_decoding"], "linear");
  EXPECT_EQ(rep["lookup"]["albedo"], "diffuse");
  EXPECT_EQ(rep["texels"], kW * kH);
  EXPECT_LT(rep["delta_e76"]["max"].get<double>(), 0.2) << rep.dump();
  EXPECT_LE(rep["delta_e76"]["median"].get<double>(), rep["delta_e76"]["p95"].get<double>());
  EXPECT_EQ(rep["unreachable"]["texels"], 0);
  EXPECT_EQ(rep["parameters"][0]["name"], kMelanin);
  EXPECT_EQ(rep["parameters"][1]["map"], "layers1.components0.fraction.png");
  // The materials map binds the maps with the ranges they encode, to the stack by its absolute
  // path, under the stack's name.
  const nlohmann::json map = nlohmann::json::parse(slurp(dir_ + "/out/materials.json"));
  ASSERT_TRUE(map.contains("skin")) << map.dump();
  EXPECT_EQ(map["skin"]["stack"], std::filesystem::weakly_canonical(kSkin).string());
  EXPECT_EQ(map["skin"]["bind"][0]["parameter"], kMelanin);
  EXPECT_EQ(map["skin"]["bind"][0]["texture"], "layers0.components0.fraction.png");
  EXPECT_EQ(map["skin"]["bind"][1]["range"], nlohmann::json::array({0.0, 0.2}));
  // The fitted albedo image is the texture to 8-bit sRGB.
  const lamina::Image fitted = lamina::read_image(dir_ + "/out/fitted_albedo.png");
  ASSERT_EQ(fitted.width, kW);
  for (std::size_t i = 0; i < fitted.rgb.size(); ++i)
    EXPECT_NEAR(lamina::srgb_encode(fitted.rgb[i]), lamina::srgb_encode(albedo_.rgb[i]), 1.0 / 255);
}

// --albedo total: the table holds R_hemispherical, 0.077 lighter than the diffuse albedo this
// texture is made of (the top's specular reflection), so the dark end of the texture is out of
// its reach: the same texture matches far worse.
TEST_F(CliFitAlbedo, TotalAlbedoIsAnotherQuantity) {
  const CliResult r = run(fit_albedo("albedo.exr", " --albedo total"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json rep = nlohmann::json::parse(slurp(dir_ + "/out/albedo_fit.json"));
  EXPECT_EQ(rep["lookup"]["albedo"], "total");
  EXPECT_GT(rep["delta_e76"]["max"].get<double>(), 2.3) << rep.dump();
  EXPECT_GT(worst_map_error(), 0.1);
}

// sRGB decoding, explicitly: the same albedo as an 8-bit sRGB PNG is decoded (the file's rule,
// or --texture-decoding srgb, the same maps) and matched to within the 8-bit rounding: the
// fitted albedo, stored as sRGB, is the texture's stored values to a step or two (the table at
// the true fractions is Delta E < 0.7 from the rounded colour). Read as linear
// (--texture-decoding linear) the colours are far lighter than the skin can be: the fitted
// albedo is far from the stored values and most texels are not reachable. (The fractions are
// not compared here: at high melanin the 8-bit rounding alone moves blood by up to 0.69 of its
// range, materials/fit/albedo_lookup.h.)
TEST_F(CliFitAlbedo, SrgbTextureIsDecoded) {
  lamina::write_png(dir_ + "/albedo.png", albedo_);
  // The largest difference between fitted_albedo.png and the texture, in 8-bit steps.
  auto worst_steps = [&] {
    const lamina::Image a = lamina::read_image(dir_ + "/albedo.png"), b = lamina::read_image(dir_ + "/out/fitted_albedo.png");
    double worst = 0.0;
    for (std::size_t i = 0; i < a.rgb.size(); ++i)
      worst = std::max(worst, 255.0 * std::abs(lamina::srgb_encode(a.rgb[i]) - lamina::srgb_encode(b.rgb[i])));
    return worst;
  };
  const CliResult r = run(fit_albedo("albedo.png"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(sRGB decoded, diffuse albedo)"), std::string::npos) << r.out;
  const nlohmann::json rep = nlohmann::json::parse(slurp(dir_ + "/out/albedo_fit.json"));
  EXPECT_EQ(rep["texture_decoding"], "srgb");
  EXPECT_LT(rep["delta_e76"]["max"].get<double>(), 0.7) << rep.dump();
  EXPECT_LE(worst_steps(), 2.0);
  const std::string map = slurp(dir_ + "/out/layers1.components0.fraction.png");
  ASSERT_EQ(run(fit_albedo("albedo.png", " --texture-decoding srgb")).exit_code, 0);
  EXPECT_TRUE(slurp(dir_ + "/out/layers1.components0.fraction.png") == map);
  const CliResult lin = run(fit_albedo("albedo.png", " --texture-decoding linear"));
  ASSERT_EQ(lin.exit_code, 0) << lin.err;
  const nlohmann::json rl = nlohmann::json::parse(slurp(dir_ + "/out/albedo_fit.json"));
  EXPECT_EQ(rl["texture_decoding"], "linear");
  EXPECT_GT(rl["unreachable"]["texels"].get<int>(), kW * kH / 2) << rl.dump();
  EXPECT_GT(worst_steps(), 20.0);
}

// The maps, the materials map and the fitted albedo are the same bytes for 1 and 2 threads; the
// report differs only in its times and the thread count. A texel no skin can have (saturated
// blue) is counted as not reachable.
TEST_F(CliFitAlbedo, SameOutputForAnyThreadCount) {
  albedo_.pixel(3, 2)[0] = 0.0f, albedo_.pixel(3, 2)[1] = 0.0f, albedo_.pixel(3, 2)[2] = 0.8f;
  lamina::write_exr(dir_ + "/albedo.exr", albedo_);
  const char* files[] = {"layers0.components0.fraction.png", "layers1.components0.fraction.png", "materials.json",
                         "fitted_albedo.png"};
  std::string first[4];
  nlohmann::json report[2];
  for (int threads : {1, 2}) {
    const CliResult r = run(fit_albedo("albedo.exr", " --threads " + std::to_string(threads)));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    report[threads - 1] = nlohmann::json::parse(slurp(dir_ + "/out/albedo_fit.json"));
    for (int f = 0; f < 4; ++f) {
      const std::string bytes = slurp(dir_ + "/out/" + files[f]);
      ASSERT_FALSE(bytes.empty()) << files[f];
      if (threads == 1) first[f] = bytes;
      else EXPECT_TRUE(bytes == first[f]) << files[f];
    }
  }
  EXPECT_EQ(report[0]["threads"], 1);
  for (nlohmann::json& j : report) j.erase("seconds"), j.erase("threads");
  EXPECT_EQ(report[0], report[1]);
  EXPECT_EQ(report[0]["unreachable"]["texels"], 1) << report[0].dump();
  EXPECT_GT(report[0]["delta_e76"]["max"].get<double>(), 20.0);
}

TEST_F(CliFitAlbedo, BadInputIsOneLineErrorAndNoOutput) {
  std::ofstream(dir_ + "/garbage.png") << "this is not a PNG file\n";
  std::ofstream(dir_ + "/a_file") << "x";
  struct Case {
    std::string args, message;
    int exit_code;
  } cases[] = {
      {fit_albedo("absent.png"), "absent.png", 1},
      {fit_albedo("garbage.png"), "cannot read '" + dir_ + "/garbage.png'", 1},
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/albedo.exr --param '" + kMelanin + "=0.3:0' --param '" + kBlood +
           "=0:0.2' --out-dir " + dir_ + "/out",
       "layers[0].components[0].fraction: bounds must be finite, increasing", 1},
      // The axes are checked before the texture is read.
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/garbage.png --param '" + kMelanin + "=0:1.5' --param '" + kBlood +
           "=0:0.2' --out-dir " + dir_ + "/out",
       "skin.json: layers[0].components[0].fraction: bounds must be finite, increasing and inside [0, 1] (got 0:1.5)", 1},
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/albedo.exr --param 'layers[7].thickness=0:1' --param '" + kBlood +
           "=0:0.2' --out-dir " + dir_ + "/out",
       "skin.json: layers[7].thickness: the stack has", 1},
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/albedo.exr --param 'below.lambert=0:1' --param '" + kBlood +
           "=0:0.2' --out-dir " + dir_ + "/out",
       "skin.json: below.lambert", 1},
      {"fit " + dir_ + "/absent.json --albedo-texture " + dir_ + "/albedo.exr" + kAxes + " --out-dir " + dir_ + "/out",
       "absent.json", 1},
      {fit_albedo("albedo.exr", " --param 'layers[1].thickness=0.5:2'"), "exactly two parameters: give two --param (got 3)", 2},
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/albedo.exr" + kAxes + " --out-dir " + dir_ + "/absent_dir",
       "--out-dir '" + dir_ + "/absent_dir': does not exist", 2},
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/albedo.exr" + kAxes + " --out-dir " + dir_ + "/a_file",
       "--out-dir '" + dir_ + "/a_file': not a directory", 2},
      {"fit " + kSkin + " --albedo-texture " + dir_ + "/albedo.exr" + kAxes, "give --out-dir DIR", 2},
      {fit_albedo("albedo.exr", " --data " + dir_ + "/m.csv"), "--data: not with --albedo-texture", 2},
      {fit_albedo("albedo.exr", " --texture-decoding gamma"), "--texture-decoding", 2},
      {fit_albedo("albedo.exr", " --lookup-nodes 1"), "--lookup-nodes", 2},
      {"fit " + kSkin + " --data " + dir_ + "/m.csv" + kAxes + " --out-dir " + dir_ + "/out", "--out-dir: only with --albedo-texture", 2},
  };
  for (const Case& c : cases) {
    const CliResult r = run(c.args);
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << ": " << r.err;
    EXPECT_TRUE(out_is_empty()) << c.args;
  }
  // An output path taken by a directory: refused before anything is read or written, and the
  // other outputs do not appear.
  std::filesystem::create_directory(dir_ + "/out/materials.json");
  const CliResult r = run(fit_albedo("albedo.exr"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("materials.json' is a directory"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/out/albedo_fit.json"));
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/out/layers0.components0.fraction.png"));
  // A texel that is not a number names the file and the texel.
  std::filesystem::remove(dir_ + "/out/materials.json");
  albedo_.pixel(5, 1)[1] = std::nanf("");
  lamina::write_exr(dir_ + "/nan.exr", albedo_);
  const CliResult nan = run(fit_albedo("nan.exr"));
  EXPECT_EQ(nan.exit_code, 1);
  EXPECT_NE(nan.err.find("nan.exr: texel (5, 1) is not finite"), std::string::npos) << nan.err;
  EXPECT_TRUE(out_is_empty());
}

}  // namespace
