// materials/spectral/prospect: the plate model's pieces against independent quadratures
// (Fresnel averaged over the cone, diffuse transmission), the pile of plates against adding two
// plates by hand, energy conservation, and the whole PROSPECT-D against prosail 2.0.5
// (tests/data/prospect_d_reference.csv, scripts/spectral_reference.py) within 1e-4.
#include "materials/spectral/prospect.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/interfaces/fresnel.h"

namespace lamina {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Midpoint rule with many panels on [a, b]: an estimator independent of the closed forms.
template <class F>
double integrate(F f, double a, double b, int panels = 200000) {
  const double h = (b - a) / panels;
  double sum = 0.0;
  for (int i = 0; i < panels; ++i) sum += f(a + (i + 0.5) * h);
  return sum * h;
}

// Isotropic radiance within the cone alpha: the transmitted fraction is
//   int_{cos alpha}^1 (1 - F(mu)) 2 mu dmu / sin^2 alpha,
// F the unpolarised Fresnel reflectance from air into index n.
TEST(Prospect, AverageTransmissivityIsFresnelAveragedOverTheCone) {
  for (double n : {1.33, 1.4, 1.5115, 1.6}) {
    for (double alpha : {40.0, 60.0, 90.0}) {
      const double mu0 = std::cos(alpha * kPi / 180.0);
      const double s2 = 1.0 - mu0 * mu0;
      const double quadrature =
          integrate([n](double mu) { return (1.0 - fresnel_dielectric(mu, 1.0, n)) * 2.0 * mu; }, mu0, 1.0) / s2;
      EXPECT_NEAR(average_transmissivity(alpha, n), quadrature, 1e-7) << "n " << n << " alpha " << alpha;
    }
  }
}

// 2 int_0^1 exp(-k / mu) mu dmu against the closed form with E1.
TEST(Prospect, DiffuseTransmissionIsTheCosineWeightedAverage) {
  EXPECT_EQ(diffuse_transmission(0.0), 1.0);
  for (double k : {1e-3, 0.05, 0.5, 2.0, 10.0}) {
    const double quadrature = integrate([k](double mu) { return 2.0 * mu * std::exp(-k / mu); }, 0.0, 1.0);
    EXPECT_NEAR(diffuse_transmission(k), quadrature, 1e-9) << "k " << k;
  }
}

// Two plates by hand: the second seen through the first's multiple reflections,
//   R2 = r + t^2 r / (1 - r^2),  T2 = t^2 / (1 - r^2); one plate is no pile at all.
TEST(Prospect, StokesPileAddsPlates) {
  const PlateOptics one = plate(40.0, 1.5, 0.7, false);
  const PlateOptics none = stokes_pile(one, 1.0);
  EXPECT_NEAR(none.reflectance, 0.0, 1e-14);
  EXPECT_NEAR(none.transmittance, 1.0, 1e-14);
  const PlateOptics just_one = stokes_pile(one, 2.0);
  EXPECT_NEAR(just_one.reflectance, one.reflectance, 1e-12);
  EXPECT_NEAR(just_one.transmittance, one.transmittance, 1e-12);
  const PlateOptics two = stokes_pile(one, 3.0);
  const double r = one.reflectance, t = one.transmittance;
  EXPECT_NEAR(two.reflectance, r + t * t * r / (1.0 - r * r), 1e-12);
  EXPECT_NEAR(two.transmittance, t * t / (1.0 - r * r), 1e-12);
}

// Without absorbers nothing is lost (R + T = 1 for any structure); with them, R + T < 1 and both
// in [0, 1].
TEST(Prospect, ConservesEnergy) {
  ProspectParameters clear;
  clear.chlorophyll = clear.carotenoids = clear.water = clear.dry_matter = 0.0;
  for (double n : {1.0, 1.37, 2.0, 3.0})
    for (double nm : {400.0, 550.0, 1450.0, 2500.0}) {
      clear.n = n;
      const PlateOptics leaf = prospect_d(clear, nm);
      EXPECT_NEAR(leaf.reflectance + leaf.transmittance, 1.0, 1e-12) << "N " << n << " nm " << nm;
    }
  const ProspectParameters green;
  for (double nm = 400.0; nm <= 2500.0; nm += 7.0) {
    const PlateOptics leaf = prospect_d(green, nm);
    EXPECT_GT(leaf.reflectance, 0.0);
    EXPECT_GE(leaf.transmittance, 0.0);
    EXPECT_LT(leaf.reflectance + leaf.transmittance, 1.0) << nm;
  }
}

TEST(Prospect, ValidatesItsParameters) {
  ProspectParameters p;
  EXPECT_NO_THROW(validate(p));
  p.n = 0.9;
  EXPECT_THROW(validate(p), std::invalid_argument);
  p = ProspectParameters();
  p.water = -0.001;
  EXPECT_THROW(validate(p), std::invalid_argument);
  p = ProspectParameters();
  p.chlorophyll = NAN;
  EXPECT_THROW(validate(p), std::invalid_argument);
}

// The reference's leaves, in the order of its columns (scripts/spectral_reference.py, LEAVES).
std::vector<ProspectParameters> reference_leaves() {
  auto leaf = [](double n, double cab, double car, double ant, double brown, double cw, double cm) {
    ProspectParameters p;
    p.n = n, p.chlorophyll = cab, p.carotenoids = car, p.anthocyanins = ant, p.brown = brown, p.water = cw,
    p.dry_matter = cm;
    return p;
  };
  return {leaf(1.5, 40.0, 8.0, 0.0, 0.0, 0.010, 0.009), leaf(1.2, 5.0, 1.0, 0.5, 0.0, 0.005, 0.002),
          leaf(2.5, 100.0, 25.0, 5.0, 0.5, 0.034, 0.030), leaf(1.0, 20.0, 4.0, 10.0, 1.0, 0.020, 0.012),
          leaf(3.0, 0.8, 2.0, 1.0, 2.0, 0.004, 0.033)};
}

TEST(Prospect, ReproducesProsailWithin1e4) {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/tests/data/prospect_d_reference.csv");
  ASSERT_TRUE(in) << "tests/data/prospect_d_reference.csv";
  const std::vector<ProspectParameters> leaves = reference_leaves();
  std::string line;
  int rows = 0;
  double worst = 0.0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("nm,", 0) == 0) continue;
    std::stringstream ss(line);
    std::string field;
    std::vector<double> v;
    while (std::getline(ss, field, ',')) v.push_back(std::stod(field));
    ASSERT_EQ(v.size(), 1 + 2 * leaves.size()) << line;
    for (size_t i = 0; i < leaves.size(); ++i) {
      const PlateOptics leaf = prospect_d(leaves[i], v[0]);
      EXPECT_NEAR(leaf.reflectance, v[1 + 2 * i], 1e-4) << "leaf " << i << " nm " << v[0];
      EXPECT_NEAR(leaf.transmittance, v[2 + 2 * i], 1e-4) << "leaf " << i << " nm " << v[0];
      worst = std::max({worst, std::abs(leaf.reflectance - v[1 + 2 * i]), std::abs(leaf.transmittance - v[2 + 2 * i])});
    }
    ++rows;
  }
  EXPECT_EQ(rows, 2101);
  std::printf("PROSPECT-D against prosail 2.0.5: largest |difference| %.3g over %d wavelengths x %zu leaves\n", worst,
              rows, leaves.size());
}

}  // namespace
}  // namespace lamina
