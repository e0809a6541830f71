// The skin-tone presets (scenes/spectral/skin_tone_*.json, written by scripts/skin_tones.py from the
// NIST fits, listed in scenes/spectral/skin_tones.csv; docs/skin_tones.md): each loads in the RGB
// and the spectral reader; darker presets (more melanin) reflect less in every RGB channel; and a
// measured preset's spectrum lies within the spread of the NIST subjects it stands for, allowing
// the model's own residual there (the median RMSE of those subjects' fits, docs/nist_skin_fit.csv):
// a preset that drifts from its subjects (an edited file, a change of a chromophore table) fails.
// The order is by construction (scripts/skin_tones.py): a darker tone holds at least as much
// eumelanin and pheomelanin as the lighter one and everything else is the same.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/adding_doubling/spectral_totals.h"
#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

std::string source(const std::string& rel) { return std::string(LAMINA_SOURCE_DIR) + "/" + rel; }

// The rows of a CSV (comment lines start with '#'), as text cells; quoted cells hold no commas here
// but the last, which is dropped.
std::vector<std::vector<std::string>> read_csv(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

struct Tone {
  std::string name;
  double melanin;
  std::vector<int> subjects;
};

std::vector<Tone> read_tones() {
  std::vector<Tone> tones;
  const auto rows = read_csv(source("scenes/spectral/skin_tones.csv"));
  for (std::size_t i = 1; i < rows.size(); ++i) {
    Tone t{rows[i][0], std::stod(rows[i][1]), {}};
    std::stringstream ss(rows[i][6]);
    for (int s; ss >> s;) t.subjects.push_back(s);
    tones.push_back(t);
  }
  return tones;
}

std::string preset(const Tone& t) { return source("scenes/spectral/" + t.name + ".json"); }

const double kCosEight = std::cos(8.0 * 3.14159265358979323846 / 180.0);  // the NIST geometry

TEST(SkinTones, LoadAndDarkenWithMelaninInEveryChannel) {
  const std::vector<Tone> tones = read_tones();
  ASSERT_GE(tones.size(), 6u);
  Spectrum previous(2.0);
  double previous_melanin = -1.0;
  for (const Tone& t : tones) {
    SCOPED_TRACE(t.name);
    const SpectralStack spectral = load_spectral_stack(preset(t));
    ASSERT_TRUE(spectral.chromophores[0]);
    EXPECT_EQ(spectral.chromophores[0]->melanin, t.melanin);
    EXPECT_GT(t.melanin, previous_melanin);
    const LayerStack rgb = load_stack_file(preset(t));
    const AddingDoublingTotals totals = adding_doubling_totals(rgb, kCosEight);
    const Spectrum r = totals.R_specular + totals.R_diffuse;
    for (int c = 0; c < kChannels; ++c) EXPECT_LT(r[c], previous[c]) << "channel " << c;
    previous = r;
    previous_melanin = t.melanin;
  }
  EXPECT_GE(previous_melanin, 0.4);  // to Fitzpatrick VI: the top of Jacques' melanosome range
}

// Each tone differs from the lighter one by more melanin of each kind, nothing else: so it absorbs
// more at every wavelength. The files hold five decimals, so each amount may fall by the product's
// rounding (5e-6 of the fraction times a share of at most 1, plus the same the other way).
TEST(SkinTones, DarkerTonesAddMelaninOfEachKindAndNothingElse) {
  const std::vector<Tone> tones = read_tones();
  const SpectralStack first = load_spectral_stack(preset(tones[0]));
  double eu = 0.0, pheo = 0.0;
  for (const Tone& t : tones) {
    SCOPED_TRACE(t.name);
    const SpectralStack s = load_spectral_stack(preset(t));
    ASSERT_EQ(s.chromophores.size(), first.chromophores.size());
    const SkinChromophores& epidermis = *s.chromophores[0];
    EXPECT_GE(epidermis.melanin * epidermis.eumelanin, eu - 1e-5);
    EXPECT_GE(epidermis.melanin * (1.0 - epidermis.eumelanin), pheo - 1e-5);
    eu = epidermis.melanin * epidermis.eumelanin;
    pheo = epidermis.melanin * (1.0 - epidermis.eumelanin);
    EXPECT_NEAR(epidermis.baseline, 1.0 - epidermis.melanin, 1e-12);  // fills the rest
    const SkinChromophores& dermis = *s.chromophores[1], &first_dermis = *first.chromophores[1];
    for (auto member : {&SkinChromophores::blood, &SkinChromophores::oxygenation, &SkinChromophores::water,
                        &SkinChromophores::fat, &SkinChromophores::carotene, &SkinChromophores::baseline, &SkinChromophores::g})
      EXPECT_EQ(dermis.*member, first_dermis.*member);
    EXPECT_EQ(dermis.scattering.reduced_500, first_dermis.scattering.reduced_500);
    EXPECT_EQ(s.stack.layers[0].thickness, first.stack.layers[0].thickness);
  }
}

TEST(SkinTones, MeasuredTonesLieWithinTheirSubjects) {
  // The NIST spectra, 400-1000 nm every 10 nm: column s is subject s.
  const auto nist = read_csv(source("data/nist_skin/nist_skin_reflectance.csv"));
  std::map<int, double> fit_rmse;
  const auto fits = read_csv(source("docs/nist_skin_fit.csv"));
  for (std::size_t i = 1; i < fits.size(); ++i) fit_rmse[std::stoi(fits[i][0])] = std::stod(fits[i][1]);
  ASSERT_EQ(fit_rmse.size(), 100u);
  int measured = 0;
  for (const Tone& t : read_tones()) {
    if (t.subjects.empty()) continue;  // extrapolated: no subjects
    SCOPED_TRACE(t.name);
    ++measured;
    std::vector<double> rmse;
    for (int s : t.subjects) rmse.push_back(fit_rmse.at(s));
    std::nth_element(rmse.begin(), rmse.begin() + rmse.size() / 2, rmse.end());
    const double tolerance = rmse[rmse.size() / 2];
    const SpectralTotals model = adding_doubling_spectrum(load_spectral_stack(preset(t)),
                                                          WavelengthGrid::from_to(400.0, 1000.0, 50.0), kCosEight);
    for (std::size_t i = 0; i < model.nm.size(); ++i) {
      const AddingDoublingTotals& m = model.estimates[i].totals;
      const double r = m.R_specular[0] + m.R_diffuse[0];
      const std::size_t row = 1 + static_cast<std::size_t>(std::lround((model.nm[i] - 400.0) / 10.0));
      ASSERT_EQ(std::stod(nist[row][0]), model.nm[i]);
      double lo = 1.0, hi = 0.0;
      for (int s : t.subjects) {
        lo = std::min(lo, std::stod(nist[row][s]));
        hi = std::max(hi, std::stod(nist[row][s]));
      }
      EXPECT_GE(r, lo - tolerance) << model.nm[i] << " nm";
      EXPECT_LE(r, hi + tolerance) << model.nm[i] << " nm";
    }
  }
  EXPECT_GE(measured, 4);
}

}  // namespace
}  // namespace lamina
