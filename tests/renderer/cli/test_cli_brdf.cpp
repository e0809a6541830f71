// `lamina brdf` end to end: exit codes, one-line errors, the CSV header and size, the JSON
// totals (summing to 1), determinism of the output files.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/renderer/cli/cli_runner.h"

namespace {

using CommandResult = lamina::test::CliResult;
using lamina::test::slurp;

// Runs `lamina ARGS` through the shell, capturing stdout and stderr in files of the test's own
// temporary folder.
class CliBrdf : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/lamina_cli_brdf_XXXXXX";
    dir_ = mkdtemp(tmpl);
    stack_ = dir_ + "/slab.json";
    std::ofstream(stack_) << R"({ "lamina_material": 1, "name": "slab", "above_ior": 1.0,
      "layers": [ { "name": "a", "ior": 1.4, "thickness": 0.2, "sigma_a": [0.5, 1.0, 2.0],
                    "sigma_s": 8.0, "g": 0.5 } ], "below": { "ior": 1.0 } })";
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }

  CommandResult run(const std::string& args) { return lamina::test::run_lamina(dir_, args); }
  // A failing run: non-zero exit and exactly one line on stderr that says what is wrong.
  void expect_one_line_error(const std::string& args, const std::string& must_contain) {
    const CommandResult r = run(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(must_contain), std::string::npos) << args << ": " << r.err;
  }

  std::string dir_, stack_;
};

TEST_F(CliBrdf, HelpExitsZero) {
  const CommandResult r = run("brdf --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--theta-i"), std::string::npos);
}

TEST_F(CliBrdf, MonteCarloWritesTableAndTotals) {
  const std::string csv = dir_ + "/t.csv", json = dir_ + "/t.json";
  const CommandResult r = run("brdf " + stack_ + " --theta-i 30 --samples 4000 --bins-theta 3 --bins-phi 5 --out " + csv +
                    " --summary " + json);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream lines(slurp(csv));
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(header, "side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple");
  int rows = 0;
  for (std::string line; std::getline(lines, line);) ++rows;
  EXPECT_EQ(rows, 2 * 3 * 5 * 3);
  const nlohmann::json j = nlohmann::json::parse(slurp(json));
  for (int c = 0; c < 3; ++c) {
    double sum = 0.0;
    for (const char* key : {"R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed"}) {
      ASSERT_TRUE(j.contains(key) && j.contains(std::string(key) + "_stderr")) << key;
      sum += j[key][c].get<double>();
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  std::uint64_t walks = 0;
  for (const auto& [name, count] : j["walk_ends"].items()) walks += count.get<std::uint64_t>();
  EXPECT_EQ(walks, 4000u);
  // No temporary files left behind (atomic write by rename).
  EXPECT_EQ(std::system(("ls '" + dir_ + "' | grep -q '\\.tmp-'").c_str()) != 0, true);
}

TEST_F(CliBrdf, FirstOrderTotalsSumToOne) {
  const CommandResult r = run("brdf " + stack_ + " --theta-i 60 --method first-order --bins-theta 2 --bins-phi 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  for (int c = 0; c < 3; ++c) {
    const double sum = j["R_specular"][c].get<double>() + j["R_diffuse"][c].get<double>() +
                       j["T_ballistic"][c].get<double>() + j["T_diffuse"][c].get<double>() +
                       j["absorbed"][c].get<double>();
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_EQ(j["R_diffuse_stderr"][c].get<double>(), 0.0);
  }
}

// A diffuse interface (top_diffuse): the first-order solution does not model it and says so in
// one line naming the file and the JSON path.
TEST_F(CliBrdf, FirstOrderRefusesDiffuseInterfaces) {
  const std::string diffuse = dir_ + "/diffuse.json";
  std::ofstream(diffuse) << R"({ "lamina_material": 1, "top_diffuse": true,
      "layers": [ { "ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 8.0, "g": 0.5 } ], "below": { "ior": 1.0 } })";
  expect_one_line_error("brdf " + diffuse + " --theta-i 30 --method first-order", diffuse + ": top_diffuse: the first-order");
}

// A diffuse top and bottom (PROSPECT's plate surfaces): adding-doubling and the walk read the
// file and report totals that sum to 1.
TEST_F(CliBrdf, DiffuseInterfacesRunInBothMethods) {
  const std::string diffuse = dir_ + "/diffuse.json";
  std::ofstream(diffuse) << R"({ "lamina_material": 1, "top_diffuse": true,
      "layers": [ { "ior": 1.4, "thickness": 0.2, "sigma_a": 0.5, "sigma_s": 8.0, "g": 0.5, "bottom_diffuse": true } ],
      "below": { "ior": 1.0 } })";
  for (const char* method : {"adding-doubling", "monte-carlo"}) {
    const CommandResult r = run("brdf " + diffuse + " --theta-i 30 --samples 2000 --bins-theta 2 --bins-phi 2 --method " + method);
    ASSERT_EQ(r.exit_code, 0) << method << ": " << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    for (int c = 0; c < 3; ++c) {
      double sum = 0.0;
      for (const char* key : {"R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed"}) sum += j[key][c].get<double>();
      EXPECT_NEAR(sum, 1.0, 1e-12) << method;
      EXPECT_GT(j["T_diffuse"][c].get<double>(), 0.05) << method;
    }
  }
}

TEST_F(CliBrdf, SameSeedSameBytes) {
  const std::string a = dir_ + "/a.csv", b = dir_ + "/b.csv";
  ASSERT_EQ(run("brdf " + stack_ + " --theta-i 10 --samples 3000 --seed 7 --bins-theta 2 --bins-phi 2 --out " + a).exit_code, 0);
  ASSERT_EQ(run("brdf " + stack_ + " --theta-i 10 --samples 3000 --seed 7 --bins-theta 2 --bins-phi 2 --out " + b).exit_code, 0);
  EXPECT_EQ(slurp(a), slurp(b));
}

TEST_F(CliBrdf, BadInputGivesOneLineErrors) {
  expect_one_line_error("brdf " + stack_, "--theta-i");
  expect_one_line_error("brdf " + stack_ + " --theta-i abc", "--theta-i");
  expect_one_line_error("brdf " + stack_ + " --theta-i 90", "--theta-i");
  expect_one_line_error("brdf " + stack_ + " --theta-i 10 --samples -5", "--samples");
  expect_one_line_error("brdf " + stack_ + " --theta-i 10 --bins-phi 0", "--bins-phi");
  expect_one_line_error("brdf " + stack_ + " --theta-i 10 --method magic", "--method");
  expect_one_line_error("brdf " + dir_ + "/missing.json --theta-i 10", "missing.json");
  expect_one_line_error("brdf " + stack_ + " --theta-i 10 --out /nonexistent_dir/x.csv", "/nonexistent_dir/x.csv");
  const std::string bad = dir_ + "/bad.json";
  std::ofstream(bad) << R"({ "lamina_material": 1, "layers": [ { "ior": 1.4, "thickness": 0.1,
      "sigma_a": 0.1, "sigma_s": 1.0, "g": 1.5 } ] })";
  expect_one_line_error("brdf " + bad + " --theta-i 10", "bad.json");
}

// --method adding-doubling: the totals with standard errors 0, the diffuse-incidence totals and
// the discretisation error; the five sum to 1 and agree with a Monte Carlo run of the same
// stack within 4 of its standard errors plus the stated discretisation error; the table.
TEST_F(CliBrdf, AddingDoublingWritesTotalsAndTable) {
  const std::string json = dir_ + "/ad.json", mc = dir_ + "/mc.json";
  const CommandResult r = run("brdf " + stack_ + " --theta-i 40 --method adding-doubling --summary " + json);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CommandResult m = run("brdf " + stack_ + " --theta-i 40 --samples 20000 --summary " + mc);
  ASSERT_EQ(m.exit_code, 0) << m.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(json)), k = nlohmann::json::parse(slurp(mc));
  EXPECT_EQ(j["method"], "adding-doubling");
  EXPECT_EQ(j["quadrature_points"], 16);
  for (int c = 0; c < 3; ++c) {
    double sum = 0.0;
    for (const char* key : {"R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed"}) {
      sum += j[key][c].get<double>();
      EXPECT_EQ(j[std::string(key) + "_stderr"][c].get<double>(), 0.0) << key;
      const double err = j["discretisation_error"][key][c].get<double>();
      EXPECT_GE(err, 0.0);
      EXPECT_NEAR(j[key][c].get<double>(), k[key][c].get<double>(),
                  4.0 * k[std::string(key) + "_stderr"][c].get<double>() + err + 1e-12)
          << key << " channel " << c;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_NEAR(j["R_hemispherical"][c].get<double>() + j["T_hemispherical"][c].get<double>() +
                    j["absorbed_hemispherical"][c].get<double>(),
                1.0, 1e-12);
  }
  // The table: the CSV layout of the other methods, stderr 0, and the bins' power (value times
  // projected solid angle) equal to R_diffuse and T_diffuse.
  const std::string csv = dir_ + "/ad.csv", json2 = dir_ + "/ad2.json";
  const CommandResult t = run("brdf " + stack_ + " --theta-i 40 --method adding-doubling --bins-theta 3 --bins-phi 5 --out " +
                              csv + " --summary " + json2);
  ASSERT_EQ(t.exit_code, 0) << t.err;
  const nlohmann::json j2 = nlohmann::json::parse(slurp(json2));
  EXPECT_TRUE(j2.contains("R_forward_peak") && j2.contains("T_forward_peak"));
  std::istringstream lines(slurp(csv));
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, "side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple");
  int rows = 0;
  double power[2][3] = {{0, 0, 0}, {0, 0, 0}};
  while (std::getline(lines, line)) {
    ++rows;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    ASSERT_EQ(f.size(), 8u) << line;
    const int side = f[0] == "reflect" ? 0 : 1, c = f[1] == "r" ? 0 : f[1] == "g" ? 1 : 2;
    const double mu = std::cos(std::stod(f[2]) * 3.14159265358979323846 / 180.0);
    const int k = std::min(2, static_cast<int>(mu * 3));  // the bin of the centre's cosine
    const double omega = 0.5 * ((k + 1) * (k + 1) - k * k) / 9.0 * (2.0 * 3.14159265358979323846 / 5);
    power[side][c] += std::stod(f[4]) * omega;
    EXPECT_EQ(std::stod(f[5]), 0.0);
  }
  EXPECT_EQ(rows, 2 * 3 * 5 * 3);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(power[0][c], j2["R_diffuse"][c].get<double>(), 1e-7);
    EXPECT_NEAR(power[1][c], j2["T_diffuse"][c].get<double>(), 1e-7);
  }
  expect_one_line_error("brdf " + stack_ + " --theta-i 40 --method adding-doubling --quadrature-points 2",
                        "--quadrature-points");
}

}  // namespace
