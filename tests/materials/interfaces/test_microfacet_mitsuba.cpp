// Lamina's rough dielectric and rough conductor (materials/interfaces/microfacet.h) against Mitsuba 3's
// roughdielectric and roughconductor at 600 random direction pairs (tests/data/
// mitsuba_microfacet.csv, written by scripts/mitsuba_reference.py with Mitsuba 3.9.1): an
// independent implementation of the same formulas (Walter et al. 2007; Heitz 2014, 2018).
// Mitsuba 3 uses the separable Smith masking-shadowing G1(v) G1(l); Lamina the height-correlated
// G2 = 1 / (1 + Lambda(v) + Lambda(l)) (pbrt-v4's). So Lamina's value times G1 G1 / G2 must
// equal Mitsuba's: D, Fresnel (dielectric and complex conductor), half vectors, the refraction
// Jacobian and the n^2 law of radiance all take part. (G2 itself is tested against its analytic
// furnace value in test_microfacet.cpp.)
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/interfaces/microfacet.h"

namespace lamina {
namespace {

struct Row {
  std::string kind;
  double alpha, ior, k;
  glm::dvec3 v, l;
  double mitsuba;
};

std::vector<Row> read_rows() {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/tests/data/mitsuba_microfacet.csv");
  EXPECT_TRUE(in.good()) << "tests/data/mitsuba_microfacet.csv missing";
  std::vector<Row> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("kind", 0) == 0) continue;
    std::stringstream ss(line);
    Row r;
    std::string cell;
    std::vector<double> x;
    std::getline(ss, r.kind, ',');
    while (std::getline(ss, cell, ',')) x.push_back(std::stod(cell));
    EXPECT_EQ(x.size(), 10u) << line;
    if (x.size() != 10u) continue;
    r.alpha = x[0];
    r.ior = x[1];
    r.k = x[2];
    r.v = {x[3], x[4], x[5]};
    r.l = {x[6], x[7], x[8]};
    r.v /= glm::length(r.v);  // the CSV's 9 digits
    r.l /= glm::length(r.l);
    r.mitsuba = x[9];
    rows.push_back(r);
  }
  return rows;
}

TEST(MicrofacetMitsuba, SameValuesUpToTheMaskingModel) {
  const std::vector<Row> rows = read_rows();
  ASSERT_EQ(rows.size(), 600u);
  int nonzero = 0, transmissions = 0;
  for (const Row& r : rows) {
    const GgxDistribution d{r.alpha};
    double ours = 0.0;
    if (r.kind == "dielectric") {
      ours = RoughDielectric{d, 1.0, r.ior}.eval(r.v, r.l) * std::abs(r.l.z);
      transmissions += r.v.z * r.l.z < 0.0 && ours > 0.0 ? 1 : 0;
    } else {
      RoughConductor c;
      c.distribution = d;
      c.eta = Spectrum(r.ior);
      c.k = Spectrum(r.k);
      ours = c.eval(r.v, r.l)[0] * std::abs(r.l.z);
    }
    const double separable = ours > 0.0 ? ours * d.g1(r.v) * d.g1(r.l) / d.g2(r.v, r.l) : 0.0;
    // Mitsuba computes in single precision.
    EXPECT_NEAR(separable, r.mitsuba, 2e-4 * r.mitsuba + 1e-6)
        << r.kind << " alpha " << r.alpha << " ior " << r.ior << " v " << r.v.x << " " << r.v.y << " " << r.v.z
        << " l " << r.l.x << " " << r.l.y << " " << r.l.z;
    nonzero += r.mitsuba > 1e-6 ? 1 : 0;
  }
  EXPECT_GT(nonzero, 300);
  EXPECT_GT(transmissions, 30);
}

}  // namespace
}  // namespace lamina
