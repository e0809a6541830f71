// materials/spectral: tabulated spectra (interpolation, held ends, validation) and the colour of
// a spectrum (CIE 1931 2 degree, D65, linear Rec. 709) against colour-science
// (tests/data/spectral_colour_reference.csv, scripts/spectral_reference.py).
#include "materials/spectral/colour.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/spectral/tabulated_spectrum.h"

namespace lamina {
namespace {

TEST(TabulatedSpectrum, InterpolatesLinearlyAndHoldsItsEnds) {
  const TabulatedSpectrum s({400.0, 500.0, 700.0}, {1.0, 3.0, 2.0});
  EXPECT_DOUBLE_EQ(s(400.0), 1.0);
  EXPECT_DOUBLE_EQ(s(450.0), 2.0);
  EXPECT_DOUBLE_EQ(s(500.0), 3.0);
  EXPECT_DOUBLE_EQ(s(650.0), 2.25);
  EXPECT_DOUBLE_EQ(s(300.0), 1.0);
  EXPECT_DOUBLE_EQ(s(900.0), 2.0);
  EXPECT_TRUE(s.covers(700.0));
  EXPECT_FALSE(s.covers(399.0));
  const std::vector<double> on_grid = s.sample(WavelengthGrid::from_to(400.0, 700.0, 100.0));
  ASSERT_EQ(on_grid.size(), 4u);
  EXPECT_DOUBLE_EQ(on_grid[2], 2.5);
}

TEST(TabulatedSpectrum, CombinesOnTheUnionOfBothGrids) {
  const TabulatedSpectrum a({400.0, 600.0}, {1.0, 3.0});
  const TabulatedSpectrum b({500.0, 700.0}, {10.0, 20.0});
  const TabulatedSpectrum c = a.combined(2.0, b, 0.5);
  EXPECT_EQ(c.wavelengths(), (std::vector<double>{400.0, 500.0, 600.0, 700.0}));
  for (double nm : {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0}) EXPECT_DOUBLE_EQ(c(nm), 2.0 * a(nm) + 0.5 * b(nm));
}

TEST(TabulatedSpectrum, RejectsBadTables) {
  EXPECT_THROW(TabulatedSpectrum({}, {}), std::invalid_argument);
  EXPECT_THROW(TabulatedSpectrum({400.0, 500.0}, {1.0}), std::invalid_argument);
  EXPECT_THROW(TabulatedSpectrum({500.0, 400.0}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(TabulatedSpectrum({400.0, 400.0}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(TabulatedSpectrum({400.0, 500.0}, {1.0, NAN}), std::invalid_argument);
  EXPECT_THROW(WavelengthGrid::from_to(500.0, 400.0, 10.0), std::invalid_argument);
}

TEST(Colour, GridAndTablesAreTheCieOnes) {
  const WavelengthGrid g = colour_grid();
  EXPECT_EQ(g.count, 85);
  EXPECT_DOUBLE_EQ(g.first_nm, 360.0);
  EXPECT_DOUBLE_EQ(g.last_nm(), 780.0);
  // CIE 015:2018 table values: ybar peaks at 555 nm with 1.0; D65 is 100 at 560 nm.
  EXPECT_DOUBLE_EQ(cie_y_bar()(555.0), 1.0);
  EXPECT_DOUBLE_EQ(illuminant_d65()(560.0), 100.0);
}

// A perfect reflector has Y = 1 by construction and lands on D65's chromaticity (x, y) =
// (0.3127, 0.3290) to the table's precision, hence near white in Rec. 709: the residual is the
// 5-nm table's white point against the colour space's rounded one (colour-science gives the same).
TEST(Colour, PerfectReflectorIsWhite) {
  const Xyz w = reflectance_to_xyz(TabulatedSpectrum::constant(1.0));
  EXPECT_DOUBLE_EQ(w.y, 1.0);
  EXPECT_NEAR(w.x / (w.x + w.y + w.z), 0.3127, 1e-4);
  EXPECT_NEAR(w.y / (w.x + w.y + w.z), 0.3290, 1e-4);
  const Spectrum rgb = reflectance_to_linear_rec709(TabulatedSpectrum::constant(1.0));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], 1.0, 2e-4) << c;
  // Linear: a grey of 0.18 is 0.18 times white, exactly up to rounding.
  const Spectrum grey = reflectance_to_linear_rec709(TabulatedSpectrum::constant(0.18));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(grey[c], 0.18 * rgb[c], 1e-15) << c;
}

double analytic(const std::string& kind, double a, double b, double nm) {
  if (kind == "constant") return a;
  if (kind == "gaussian") return std::exp(-0.5 * ((nm - a) / b) * ((nm - a) / b));
  if (kind == "ramp") return (nm - 360.0) / 420.0;
  throw std::runtime_error("unknown kind " + kind);
}

// Each reference spectrum is rebuilt on the 5-nm grid and its XYZ and RGB compared: the same
// integration as colour-science's, so the two agree to rounding (1e-9 of a perfect white).
TEST(Colour, MatchesColourScience) {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/tests/data/spectral_colour_reference.csv");
  ASSERT_TRUE(in) << "tests/data/spectral_colour_reference.csv";
  std::string line;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("kind,", 0) == 0) continue;
    std::stringstream ss(line);
    std::string kind, field;
    std::getline(ss, kind, ',');
    std::vector<double> v;
    while (std::getline(ss, field, ',')) v.push_back(std::stod(field));
    ASSERT_EQ(v.size(), 8u) << line;
    std::vector<double> nm, values;
    const WavelengthGrid g = colour_grid();
    for (int i = 0; i < g.count; ++i) {
      nm.push_back(g.at(i));
      values.push_back(analytic(kind, v[0], v[1], g.at(i)));
    }
    const TabulatedSpectrum s(nm, values);
    const Xyz xyz = reflectance_to_xyz(s);
    const Spectrum rgb = reflectance_to_linear_rec709(s);
    EXPECT_NEAR(xyz.x, v[2], 1e-9) << line;
    EXPECT_NEAR(xyz.y, v[3], 1e-9) << line;
    EXPECT_NEAR(xyz.z, v[4], 1e-9) << line;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], v[5 + c], 1e-9) << line << " channel " << c;
    ++rows;
  }
  EXPECT_EQ(rows, 6);
}

}  // namespace
}  // namespace lamina
