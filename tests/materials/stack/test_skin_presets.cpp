// The measured skin presets (scenes/materials/skin_{light,medium,dark}.json, fitted by
// scripts/skin_presets.py) against the NIST skin reflectance data they were fitted to
// (scenes/materials/nist_skin_rgb.csv: 100 subjects of Cooksey et al. 2017, DOI 10.18434/M38597,
// in linear Rec. 709): each preset's total reflectance at 8 degrees (the measurement's geometry),
// from the walk, lies inside the 5th..95th percentile of its third of the subjects (sorted by
// luminance) in every channel, allowing 3 standard errors of the estimate. A preset that drifts
// from the data (an edited file, a change of the walk) fails here.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/brdf/brdf_table.h"
#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

struct Subject {
  double y;
  Spectrum rgb;
};

std::vector<Subject> read_subjects() {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/nist_skin_rgb.csv");
  EXPECT_TRUE(in.good());
  std::vector<Subject> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("subject", 0) == 0) continue;
    std::stringstream ss(line);
    std::string cell;
    std::vector<double> x;
    while (std::getline(ss, cell, ',')) x.push_back(std::stod(cell));
    if (x.size() == 5) out.push_back({x[1], Spectrum(x[2], x[3], x[4])});
  }
  return out;
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double k = p * (v.size() - 1);
  const std::size_t i = static_cast<std::size_t>(k);
  return i + 1 < v.size() ? v[i] + (k - i) * (v[i + 1] - v[i]) : v.back();
}

TEST(SkinPresets, TotalReflectanceWithinTheirThirdOfTheNistSubjects) {
  std::vector<Subject> subjects = read_subjects();
  ASSERT_EQ(subjects.size(), 100u);
  std::sort(subjects.begin(), subjects.end(), [](const Subject& a, const Subject& b) { return a.y > b.y; });
  const struct {
    const char* name;
    std::size_t begin, end;
  } thirds[] = {{"light", 0, 33}, {"medium", 33, 67}, {"dark", 67, 100}};
  double previous_y = 2.0;
  for (const auto& third : thirds) {
    SCOPED_TRACE(third.name);
    const LayerStack stack = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin_" + third.name + ".json");
    BrdfOptions options;
    options.theta_i_deg = 8.0;
    options.samples = 40000;
    const BrdfTable t = brdf_table_monte_carlo(stack, options);
    double y = 0.0;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> values;
      for (std::size_t i = third.begin; i < third.end; ++i) values.push_back(subjects[i].rgb[c]);
      const double r = t.totals.R_specular.value[c] + t.totals.R_diffuse.value[c];
      const double se = std::hypot(t.totals.R_specular.stderr_[c], t.totals.R_diffuse.stderr_[c]);
      EXPECT_GE(r + 3 * se, percentile(values, 0.05)) << "channel " << c;
      EXPECT_LE(r - 3 * se, percentile(values, 0.95)) << "channel " << c;
      y += (c == 0 ? 0.2126 : c == 1 ? 0.7152 : 0.0722) * r;
    }
    EXPECT_LT(y, previous_y);  // light > medium > dark
    previous_y = y;
  }
}

}  // namespace
}  // namespace lamina
