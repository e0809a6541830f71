// `lamina brdf --wavelengths` and `lamina fit --spectrum` end to end.
// brdf: the totals per wavelength of a material with chromophore layers (arrays of the grid's
// length, energy summing to 1, a colour when the grid spans the visible), a grey material equal
// to the RGB solution at every wavelength. fit: a spectrum made by `lamina brdf --wavelengths`
// from a known melanin fraction fitted back from another start (the fitted value, a vanishing
// RMSE, the JSON's arrays), with and without the coarse model's search; without --wavelengths, the RGB reading near the spectrum's colour. Both: usage errors (exit 2) and input errors (exit 1), one line each.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/renderer/cli/cli_runner.h"
#include "tests/support/image_files.h"

namespace {

using lamina::test::CliResult;

// A two-layer skin by chromophores with the epidermis' melanin fraction given.
std::string skin(double melanin) {
  return R"({"lamina_material": 1, "layers": [
      {"ior": 1.4, "thickness": 0.1, "chromophores": {"melanin": )" + std::to_string(melanin) + R"(, "baseline": 0.5,
       "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}},
      {"ior": 1.4, "thickness": "inf", "chromophores": {"blood": 0.02, "water": 0.6, "baseline": 0.38,
       "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}}]})";
}

class CliSpectral : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/lamina_cli_spectral_XXXXXX";
    dir_ = mkdtemp(tmpl);
    skin_ = dir_ + "/skin.json";
    std::ofstream(skin_) << skin(0.03);
    std::ofstream(dir_ + "/truth.json") << skin(0.15);
    std::ofstream(dir_ + "/start.json") << skin(0.05);
    grey_ = dir_ + "/grey.json";
    std::ofstream(grey_) << R"({"lamina_material": 1, "layers": [
      {"ior": 1.4, "thickness": 0.3, "sigma_a": 0.4, "sigma_s": 6.0, "g": 0.6}]})";
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }

  CliResult run(const std::string& args) { return lamina::test::run_lamina(dir_, args); }
  void expect_one_line_error(const std::string& args, int code, const std::string& must_contain) {
    const CliResult r = run(args);
    EXPECT_EQ(r.exit_code, code) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(must_contain), std::string::npos) << args << ": " << r.err;
  }

  void write_truth_spectrum();

  std::string dir_, skin_, grey_;
};

TEST_F(CliSpectral, PrintsTotalsPerWavelength) {
  const CliResult r = run("brdf " + skin_ + " --theta-i 8 --method adding-doubling --wavelengths 380:780:20");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["wavelength_nm"].size(), 21u);
  EXPECT_EQ(j["wavelength_nm"][1].get<double>(), 400.0);
  for (const char* key : {"R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed", "R_hemispherical"})
    ASSERT_EQ(j[key].size(), 21u) << key;
  for (std::size_t i = 0; i < 21; ++i) {
    const double sum = j["R_specular"][i].get<double>() + j["R_diffuse"][i].get<double>() +
                       j["T_ballistic"][i].get<double>() + j["T_diffuse"][i].get<double>() + j["absorbed"][i].get<double>();
    EXPECT_NEAR(sum, 1.0, 1e-9) << i;
    EXPECT_EQ(j["T_diffuse"][i].get<double>(), 0.0);  // a semi-infinite dermis transmits nothing
  }
  // Skin's colour: red above green above blue.
  ASSERT_EQ(j["R_rec709"].size(), 3u);
  EXPECT_GT(j["R_rec709"][0].get<double>(), j["R_rec709"][1].get<double>());
  EXPECT_GT(j["R_rec709"][1].get<double>(), j["R_rec709"][2].get<double>());
}

TEST_F(CliSpectral, GreyMaterialEqualsTheRgbSolutionAtEveryWavelength) {
  const CliResult rgb = run("brdf " + grey_ + " --theta-i 30 --method adding-doubling");
  const CliResult spectral = run("brdf " + grey_ + " --theta-i 30 --method adding-doubling --wavelengths 500:900:100");
  ASSERT_EQ(rgb.exit_code, 0) << rgb.err;
  ASSERT_EQ(spectral.exit_code, 0) << spectral.err;
  const nlohmann::json a = nlohmann::json::parse(rgb.out), b = nlohmann::json::parse(spectral.out);
  EXPECT_EQ(b.count("R_rec709"), 0u);  // 500-900 nm does not cover the visible
  for (const char* key : {"R_diffuse", "T_diffuse", "T_ballistic", "absorbed"})
    for (std::size_t i = 0; i < 5; ++i) EXPECT_NEAR(b[key][i].get<double>(), a[key][0].get<double>(), 1e-12) << key;
}

// Rough interfaces (single-scattering top; energy-conserving top and inner interface): each
// wavelength is the same solver on the same stack as the RGB method, so a grey rough material's
// totals are the RGB totals at every wavelength, and every wavelength conserves energy.
TEST_F(CliSpectral, GreyRoughMaterialsEqualTheRgbSolutionAtEveryWavelength) {
  const std::string layers = R"("layers": [
      {"ior": 1.4, "thickness": 0.2, "sigma_a": 0.4, "sigma_s": 6.0, "g": 0.6, "bottom_roughness": 0.3},
      {"ior": 1.5, "thickness": 0.3, "sigma_a": 0.2, "sigma_s": 4.0, "g": 0.3}]})";
  const std::string single = dir_ + "/rough_single.json", conserving = dir_ + "/rough_conserving.json";
  std::ofstream(single) << R"({"lamina_material": 1, "roughness": 0.3, "interface_model": "single_scattering", "layers": [
      {"ior": 1.4, "thickness": "inf", "sigma_a": 0.4, "sigma_s": 6.0, "g": 0.6}]})";
  std::ofstream(conserving) << R"({"lamina_material": 1, "roughness": 0.5, "interface_model": "energy_conserving", )" + layers;
  for (const std::string& file : {single, conserving}) {
    const CliResult rgb = run("brdf " + file + " --theta-i 30 --method adding-doubling");
    const CliResult spectral = run("brdf " + file + " --theta-i 30 --method adding-doubling --wavelengths 500:700:100");
    ASSERT_EQ(rgb.exit_code, 0) << file << ": " << rgb.err;
    ASSERT_EQ(spectral.exit_code, 0) << file << ": " << spectral.err;
    const nlohmann::json a = nlohmann::json::parse(rgb.out), b = nlohmann::json::parse(spectral.out);
    for (std::size_t i = 0; i < 3; ++i) {
      double sum = 0.0;
      for (const char* key : {"R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed"}) {
        EXPECT_NEAR(b[key][i].get<double>(), a[key][0].get<double>(), 1e-12) << file << " " << key;
        sum += b[key][i].get<double>();
      }
      EXPECT_NEAR(sum, 1.0, 1e-9) << file << " " << i;
    }
    EXPECT_GT(b["R_diffuse"][0].get<double>(), 0.0) << file;
  }
}

TEST_F(CliSpectral, BrdfErrorsAreOneLine) {
  expect_one_line_error("brdf " + skin_ + " --theta-i 8 --method adding-doubling --wavelengths 400:700", 2,
                        "--wavelengths: expected FIRST:LAST:STEP");
  expect_one_line_error("brdf " + skin_ + " --theta-i 8 --method adding-doubling --wavelengths 700:400:10", 2,
                        "250 <= FIRST <= LAST <= 2500");
  expect_one_line_error("brdf " + skin_ + " --theta-i 8 --method adding-doubling --wavelengths 400:700:0.01", 2,
                        "at most 10000 wavelengths");
  expect_one_line_error("brdf " + skin_ + " --theta-i 8 --wavelengths 400:700:10", 2,
                        "--wavelengths needs --method adding-doubling and no --out");
  expect_one_line_error("brdf " + dir_ + "/missing.json --theta-i 8 --method adding-doubling --wavelengths 400:700:10", 1,
                        "cannot read the material file: does not exist");
}

// Without --wavelengths, `lamina brdf` reads the chromophore layers in RGB (their projection onto
// the channels, docs/skin_tones.md): its total reflectance is about the colour of the spectrum,
// within the projection's bound of test_chromophores (0.012 per channel). Replaces the refusal
// this command gave before chromophore layers had an RGB reading.
TEST_F(CliSpectral, RgbBrdfShowsAboutTheSpectrumsColour) {
  const CliResult rgb = run("brdf " + skin_ + " --theta-i 8 --method adding-doubling");
  const CliResult spectral = run("brdf " + skin_ + " --theta-i 8 --method adding-doubling --wavelengths 360:780:5");
  ASSERT_EQ(rgb.exit_code, 0) << rgb.err;
  ASSERT_EQ(spectral.exit_code, 0) << spectral.err;
  const nlohmann::json a = nlohmann::json::parse(rgb.out), b = nlohmann::json::parse(spectral.out);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(a["R_specular"][c].get<double>() + a["R_diffuse"][c].get<double>(), b["R_rec709"][c].get<double>(), 0.012) << c;
}

// spectrum.csv: the total reflectance of truth.json (melanin 0.15) by `lamina brdf
// --wavelengths` in its column R.
void CliSpectral::write_truth_spectrum() {
  const CliResult brdf = run("brdf " + dir_ + "/truth.json --theta-i 8 --method adding-doubling --quadrature-points 8 "
                             "--wavelengths 400:700:30");
  ASSERT_EQ(brdf.exit_code, 0) << brdf.err;
  const nlohmann::json b = nlohmann::json::parse(brdf.out);
  std::ofstream csv(dir_ + "/spectrum.csv");
  csv << "# made by lamina brdf\nnm,other,R\n";
  for (std::size_t i = 0; i < b["wavelength_nm"].size(); ++i)
    csv << b["wavelength_nm"][i].get<double>() << ",0," << b["R_specular"][i].get<double>() + b["R_diffuse"][i].get<double>()
        << "\n";
}

TEST_F(CliSpectral, FitsBackASpectrumOfKnownMelanin) {
  write_truth_spectrum();
  const CliResult fit = run("fit " + dir_ + "/start.json --spectrum " + dir_ + "/spectrum.csv --spectrum-column R "
                            "--param layers[0].chromophores.melanin=0:0.45 --quadrature-points 8");
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const nlohmann::json j = nlohmann::json::parse(fit.out);
  EXPECT_NEAR(j["parameters"]["layers[0].chromophores.melanin"].get<double>(), 0.15, 2e-3);
  EXPECT_LT(j["rmse"].get<double>(), 1e-3);
  EXPECT_EQ(j["column"], "R");
  EXPECT_EQ(j["measured"].size(), 11u);
  EXPECT_EQ(j["modelled"].size(), 11u);
  EXPECT_EQ(j["measured_rec709"].size(), 3u);
}

// --coarse-quadrature-points: the search's model (default 4: most solutions are on it) or none
// (0: every solution at --quadrature-points); both find the melanin fraction.
TEST_F(CliSpectral, FitSearchesOnTheCoarseModel) {
  write_truth_spectrum();
  const std::string fit = "fit " + dir_ + "/start.json --spectrum " + dir_ +
                          "/spectrum.csv --spectrum-column R --param layers[0].chromophores.melanin=0:0.45 "
                          "--quadrature-points 8";
  for (const char* coarse : {"", " --coarse-quadrature-points 0"}) {
    const CliResult r = run(fit + coarse);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_NEAR(j["parameters"]["layers[0].chromophores.melanin"].get<double>(), 0.15, 2e-3) << coarse;
    const int all = j["evaluations"].get<int>(), on_coarse = j["coarse_evaluations"].get<int>();
    if (*coarse == '\0') {
      EXPECT_GT(on_coarse, all / 2);
      EXPECT_LT(on_coarse, all);
    } else {
      EXPECT_EQ(on_coarse, 0);
    }
  }
}

TEST_F(CliSpectral, FitErrorsAreOneLine) {
  std::ofstream(dir_ + "/bad.csv") << "nm,R\n400,0.2\n390,0.3\n";
  const std::string fit = "fit " + dir_ + "/start.json --spectrum ";
  expect_one_line_error(fit + dir_ + "/bad.csv --param layers[0].chromophores.melanin=0:1 --data x.csv", 2,
                        "--data: not with --spectrum");
  expect_one_line_error("fit " + dir_ + "/start.json --spectrum-column R --data x.csv --param layers[0].sigma_a=0:1", 2,
                        "--spectrum-column and --spectrum-theta-i need --spectrum");
  expect_one_line_error(fit + dir_ + "/bad.csv --param layers[0].chromophores.melanin=0:1", 1,
                        "bad.csv: line 3: wavelengths must increase");
  expect_one_line_error(fit + dir_ + "/bad.csv --spectrum-column Q --param layers[0].chromophores.melanin=0:1", 1,
                        "bad.csv: line 1: no column 'Q'");
  expect_one_line_error(fit + dir_ + "/missing.csv --param layers[0].chromophores.melanin=0:1", 1, "missing.csv: cannot open");
  std::ofstream(dir_ + "/good.csv") << "nm,R\n400,0.2\n500,0.3\n";
  expect_one_line_error(fit + dir_ + "/good.csv --param layers[0].sigma_a=0:1", 1,
                        "layers[0].sigma_a: expected layers[i].chromophores.KEY");
}

}  // namespace

namespace {

// `lamina render --spectral` end to end: the header says so (and an RGB render's has no such
// key), what it does not render is refused in one line, and a leaf renders.
TEST_F(CliSpectral, RenderSpectralWritesItsKeyAndRefusesWhatItDoesNotRender) {
  const std::string src = LAMINA_SOURCE_DIR;
  const std::string box = src + "/scenes/cornell_box/CornellBox.glb --width 8 --height 8 --spp 2 ";
  ASSERT_EQ(run("render " + box + "--spectral -o " + dir_ + "/spectral.exr").exit_code, 0);
  ASSERT_EQ(run("render " + box + "-o " + dir_ + "/rgb.exr").exit_code, 0);
  EXPECT_NE(lamina::test::slurp(dir_ + "/spectral.exr").find("lamina:spectral"), std::string::npos);
  EXPECT_EQ(lamina::test::slurp(dir_ + "/rgb.exr").find("lamina:spectral"), std::string::npos);
  // Every --subsurface mode renders spectrally (the lambert mode on its wavelength grid:
  // docs/spectral.md, "Tables and albedos on a wavelength grid"; test_spectral_tables.cpp).
  const CliResult lambert = run("render " + box + "--spectral --subsurface lambert --stack " + skin_ + " -o " + dir_ + "/l.exr");
  EXPECT_EQ(lambert.exit_code, 0) << lambert.err;
  EXPECT_NE(lambert.out.find("spectral mode: tables and albedos on 48 wavelengths"), std::string::npos) << lambert.out;
  // A leaf (its index varies with the wavelength) renders spectrally by the walk, and by auto's
  // walk; the tabulated modes refuse it, and the RGB mode refuses leaf layers.
  const std::string leaf = " --stack " + src + "/scenes/spectral/leaf_layered.json";
  EXPECT_EQ(run("render " + box + "--spectral" + leaf + " -o " + dir_ + "/leaf.exr").exit_code, 0);
  const CliResult leaf_auto = run("render " + box + "--spectral --subsurface auto --tolerance 0.05" + leaf + " -o " + dir_ + "/leaf_auto.exr");
  EXPECT_EQ(leaf_auto.exit_code, 0) << leaf_auto.err;
  for (const char* mode : {"table", "lambert"})
    expect_one_line_error("render " + box + "--spectral --subsurface " + mode + leaf + " -o " + dir_ + "/x.exr", 1,
                          "leaf_layered.json: leaf layers are rendered spectrally by the walk alone");
  // The fitted leaf's faces are diffuse, which first-order refuses before its leaf layers.
  expect_one_line_error("render " + box + "--spectral --subsurface first-order" + leaf + " -o " + dir_ + "/x.exr", 1,
                        "leaf_layered.json: top_diffuse: first-order does not model a diffuse interface");
  expect_one_line_error("render " + box + "--spectral --subsurface first-order --stack " + src +
                            "/scenes/spectral/leaf_layered_smooth.json -o " + dir_ + "/x.exr",
                        1, "leaf_layered_smooth.json: leaf layers are rendered spectrally by the walk alone");
  expect_one_line_error("render " + box + "--stack " + src + "/scenes/spectral/leaf_layered.json -o " + dir_ + "/x.exr", 1,
                        "layers[0].leaf: a layer given by leaf contents has spectral coefficients");
  // Leaf layers bound to maps (a chlorophyll map) render spectrally; a bad key or range is refused
  // in one line naming the map, the material and the binding; the RGB mode refuses the stack.
  lamina::test::write_png8(dir_ + "/pigment.png", 2, 1, 1, {0, 255});
  auto leaf_map = [&](const std::string& parameter, const std::string& range) {
    std::ofstream(dir_ + "/leaf_map.json") << R"({"leaf": {"stack": ")" << src << R"(/scenes/spectral/leaf_layered.json",
        "bind": [{"parameter": ")" << parameter << R"(", "texture": "pigment.png", "channel": "r", "range": )" << range << "}]}}";
    return "render " + src + "/scenes/leaves/leaves_back.gltf --width 8 --height 8 --spp 1 --materials " + dir_ + "/leaf_map.json -o " +
           dir_ + "/leaf_map.exr";
  };
  const CliResult mapped = run(leaf_map("layers[1].leaf.chlorophyll", "[5, 40]") + " --spectral");
  EXPECT_EQ(mapped.exit_code, 0) << mapped.err;
  expect_one_line_error(leaf_map("layers[1].leaf.chlorophyl", "[5, 40]") + " --spectral", 1,
                        "leaf_map.json: material 'leaf': bind[0].parameter: layers[1].leaf.chlorophyl: unknown leaf key");
  expect_one_line_error(leaf_map("layers[1].leaf.scattering_power", "[0, 5]") + " --spectral", 1,
                        "leaf_map.json: material 'leaf': bind[0].range[1]: outside the range of layers[1].leaf.scattering_power");
  expect_one_line_error(leaf_map("layers[1].leaf.chlorophyll", "[5, 40]"), 1,
                        "layers[0].leaf: a layer given by leaf contents has spectral coefficients");
  // A skin by chromophores renders (the stack at each path's wavelengths).
  EXPECT_EQ(run("render " + box + "--spectral --stack " + skin_ + " -o " + dir_ + "/skin.exr").exit_code, 0);
}

}  // namespace
