// `lamina fit` end to end: the measurements come from `lamina brdf --method adding-doubling`'s
// totals of a known slab (the other command as the data source), the fit from another start
// recovers the slab and writes a material file that `lamina brdf` reads back to the same totals;
// the unidentifiable g is reported on stderr; bad input is a one-line error with a non-zero exit.
#include <sys/wait.h>
#include <unistd.h>

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
  expect_one_line_error(fit + "--data " + dir_ + "/nan.csv --param 'layers[0].sigma_a=0:1'", "nan.csv: line 2: value 'nan' is not finite");
  expect_one_line_error(fit + "--data " + dir_ + "/absent.csv --param 'layers[0].sigma_a=0:1'", "absent.csv: cannot open");
  expect_one_line_error("fit " + dir_ + "/absent.json --data " + dir_ + "/m.csv --param 'layers[0].sigma_a=0:1'", "absent.json");
}

}  // namespace
