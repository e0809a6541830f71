// `lamina fit --albedo-texture` with chromophore parameters (the spectral variant, docs/fitting.md):
// a linear texture whose texels are the forward model's colours at known (melanin, blood) comes
// back as maps of them, within the error the table has at each texel (derived as in
// tests/materials/fit/test_spectral_albedo.cpp) plus the maps' 16-bit step; the maps are the
// library's own matches to that step; colours beyond the model's gamut are counted as clamped in
// the summary line and the report; a chromophore path on a material without such layers is a
// one-line error.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/fit/spectral_albedo.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/stack_bindings.h"
#include "tests/renderer/cli/cli_runner.h"

namespace {

using lamina::test::CliResult;
using lamina::test::slurp;

const std::string kMaterial = std::string(LAMINA_SOURCE_DIR) + "/scenes/head_skin/skin_chromophores_conserving.json";
const std::vector<lamina::FitParameterSpec> kAxes = {{"layers[1].chromophores.melanin", 0.0, 0.2},
                                                     {"layers[2].chromophores.blood", 0.0, 0.1}};
constexpr int kW = 5, kH = 4;  // the last row: out of gamut
constexpr int kNodes = 9;      // a coarse table keeps the test fast; the tolerance follows from it

class CliFitSpectralAlbedo : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/lamina_cli_fit_spectral_XXXXXX";
    dir_ = mkdtemp(tmpl);
    std::filesystem::create_directory(dir_ + "/out");
    material_ = lamina::load_chromophore_material(kMaterial);
    ps_ = lamina::check_spectral_albedo_axes(material_, kAxes);
    // Rows 0-2: melanin along x, blood along y, 10-90 % of their ranges, each texel the model's
    // colour there (4 quadrature points: the variant's default). Row 3: a colour 20 % lighter than
    // no melanin gives, out of the model's gamut.
    albedo_ = lamina::Image(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const double u0 = 0.1 + 0.8 * x / (kW - 1), u1 = 0.1 + 0.8 * std::min(y, 2) / 2.0;
        const double v[2] = {y == 3 ? 0.0 : 0.2 * u0, 0.1 * u1};
        truth_[0][y * kW + x] = u0, truth_[1][y * kW + x] = u1;
        lamina::Spectrum c = lamina::spectral_albedo_colour(material_, ps_, v, lamina::AlbedoKind::kDiffuse,
                                                            lamina::AddingDoublingSettings{4});
        if (y == 3) c = 1.2 * c;
        for (int k = 0; k < 3; ++k) albedo_.pixel(x, y)[k] = static_cast<float>(c[k]);
      }
    lamina::write_exr(dir_ + "/albedo.exr", albedo_);
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }
  CliResult run(const std::string& args) { return lamina::test::run_lamina(dir_, args); }

  std::string dir_;
  lamina::ChromophoreMaterial material_;
  std::vector<lamina::StackParameter> ps_;
  lamina::Image albedo_;
  double truth_[2][kW * kH];
};

TEST_F(CliFitSpectralAlbedo, KnownMapsComeBackAndOutOfGamutTexelsAreCounted) {
  const CliResult r = run("fit " + kMaterial + " --albedo-texture " + dir_ + "/albedo.exr --param '" + kAxes[0].path +
                          "=0:0.2' --param '" + kAxes[1].path + "=0:0.1' --lookup-nodes " + std::to_string(kNodes) +
                          " --out-dir " + dir_ + "/out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The out-of-gamut row (5 texels) sits on melanin's lower bound; nothing else does.
  EXPECT_NE(r.out.find("5 texels (25.0%) clamped to a bound (out of the model's gamut); spectral lookup 9 x 9"),
            std::string::npos)
      << r.out;
  const nlohmann::json rep = nlohmann::json::parse(slurp(dir_ + "/out/albedo_fit.json"));
  EXPECT_EQ(rep["method"], "spectral-albedo-lookup");
  EXPECT_EQ(rep["lookup"]["quadrature_points"], 4);
  EXPECT_EQ(rep["clamped"]["texels"], 5);
  EXPECT_EQ(rep["parameters"][0]["texels_at_lower"], 5);
  const nlohmann::json map = nlohmann::json::parse(slurp(dir_ + "/out/materials.json"));
  EXPECT_EQ(map["skin_chromophores_conserving"]["bind"][1]["parameter"], kAxes[1].path);

  // The same table in process: the maps are its matches (to the 16-bit step), and those lie
  // within 1.5 x 2|e| / s_min of the truth (e the table's error at the truth, s_min the smaller
  // singular value of its Jacobian there; derivation in test_spectral_albedo.cpp).
  const lamina::SpectralAlbedoTable t = lamina::build_spectral_albedo_table(material_, kAxes, kNodes, lamina::AddingDoublingSettings{4},
                                                                            lamina::AlbedoKind::kDiffuse);
  lamina::ParameterMap maps[2] = {lamina::read_parameter_map(dir_ + "/out/layers1.chromophores.melanin.png"),
                                  lamina::read_parameter_map(dir_ + "/out/layers2.chromophores.blood.png")};
  constexpr double kStep = 1.0 / 65535;
  for (int i = 0; i < kW * kH; ++i) {
    const float* p = &albedo_.rgb[3 * i];
    const lamina::AlbedoMatch m = lamina::match_spectral_albedo(t, lamina::Spectrum(p[0], p[1], p[2]));
    const double got[2] = {maps[0].values[i * maps[0].channels], maps[1].values[i * maps[1].channels]};
    EXPECT_NEAR(got[0], m.value[0] / 0.2, kStep) << i;
    EXPECT_NEAR(got[1], m.value[1] / 0.1, kStep) << i;
    if (i >= 3 * kW) {
      EXPECT_EQ(got[0], 0.0) << i;  // clamped
      continue;
    }
    const double u0[2] = {truth_[0][i], truth_[1][i]};
    const lamina::Spectrum target(p[0], p[1], p[2]);
    const double e = lamina::delta_e76(lamina::linear_rgb_to_lab(t.at(u0[0], u0[1])), lamina::linear_rgb_to_lab(target));
    constexpr double h = 1e-5;
    lamina::Spectrum J[2];
    for (int a = 0; a < 2; ++a) {
      double lo[2] = {u0[0], u0[1]}, hi[2] = {u0[0], u0[1]};
      lo[a] -= h, hi[a] += h;
      J[a] = (1.0 / (2 * h)) * (lamina::linear_rgb_to_lab(t.at(hi[0], hi[1])) - lamina::linear_rgb_to_lab(t.at(lo[0], lo[1])));
    }
    auto dot = [](const lamina::Spectrum& x, const lamina::Spectrum& y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
    const double a = dot(J[0], J[0]), b = dot(J[0], J[1]), c = dot(J[1], J[1]);
    const double s_min = std::sqrt(0.5 * (a + c - std::sqrt((a - c) * (a - c) + 4 * b * b)));
    // e is computed from the float texel, as the command sees it.
    EXPECT_LE(std::hypot(got[0] - u0[0], got[1] - u0[1]), 3.0 * e / s_min + 2 * kStep + 1e-6) << i;
  }
}

TEST_F(CliFitSpectralAlbedo, ChromophorePathsNeedChromophoreLayers) {
  const CliResult r = run("fit " + std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json --albedo-texture " + dir_ +
                          "/albedo.exr --param 'layers[0].chromophores.melanin=0:0.2' --param "
                          "'layers[1].chromophores.blood=0:0.1' --out-dir " + dir_ + "/out");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("skin.json"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::is_empty(dir_ + "/out"));
}

}  // namespace
