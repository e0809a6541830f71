// `lamina fit --spectrum` end to end: a spectrum made by `lamina brdf --wavelengths` from a known
// melanin fraction is fitted back from another start (the fitted value, a vanishing RMSE, the
// JSON's arrays), and the usage (exit 2) and input (exit 1) errors, each one line.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/renderer/cli/cli_runner.h"

namespace {

using lamina::test::CliResult;

std::string skin(double melanin) {
  return R"({"lamina_material": 1, "layers": [
      {"ior": 1.4, "thickness": 0.1, "chromophores": {"melanin": )" + std::to_string(melanin) + R"(, "baseline": 0.5,
       "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}},
      {"ior": 1.4, "thickness": "inf", "chromophores": {"blood": 0.02, "water": 0.6, "baseline": 0.38,
       "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}}]})";
}

class CliFitSpectral : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/lamina_cli_fit_spectral_XXXXXX";
    dir_ = mkdtemp(tmpl);
    std::ofstream(dir_ + "/truth.json") << skin(0.15);
    std::ofstream(dir_ + "/start.json") << skin(0.05);
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }

  CliResult run(const std::string& args) { return lamina::test::run_lamina(dir_, args); }
  void expect_one_line_error(const std::string& args, int code, const std::string& must_contain) {
    const CliResult r = run(args);
    EXPECT_EQ(r.exit_code, code) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(must_contain), std::string::npos) << args << ": " << r.err;
  }

  std::string dir_;
};

TEST_F(CliFitSpectral, FitsBackASpectrumOfKnownMelanin) {
  const CliResult brdf = run("brdf " + dir_ + "/truth.json --theta-i 8 --method adding-doubling --quadrature-points 8 "
                             "--wavelengths 400:700:30");
  ASSERT_EQ(brdf.exit_code, 0) << brdf.err;
  const nlohmann::json b = nlohmann::json::parse(brdf.out);
  {
    std::ofstream csv(dir_ + "/spectrum.csv");
    csv << "# made by lamina brdf\nnm,other,R\n";
    for (std::size_t i = 0; i < b["wavelength_nm"].size(); ++i)
      csv << b["wavelength_nm"][i].get<double>() << ",0," << b["R_specular"][i].get<double>() + b["R_diffuse"][i].get<double>()
          << "\n";
  }
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

TEST_F(CliFitSpectral, ErrorsAreOneLine) {
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
