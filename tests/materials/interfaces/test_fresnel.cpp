#include "materials/interfaces/fresnel.h"

#include <cmath>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

namespace lamina {

TEST(Fresnel, NormalIncidenceMatchesClosedForm) {
  // ((n_t - n_i)/(n_t + n_i))^2 at normal incidence, from either side.
  EXPECT_NEAR(fresnel_dielectric(1.0, 1.0, 1.5), 0.04, 1e-15);
  EXPECT_NEAR(fresnel_dielectric(1.0, 1.5, 1.0), 0.04, 1e-15);
}

TEST(Fresnel, IndexRatioOneGivesZeroEvenAtGrazing) {
  EXPECT_EQ(fresnel_dielectric(1.0, 1.33, 1.33), 0.0);
  EXPECT_EQ(fresnel_dielectric(0.0, 1.33, 1.33), 0.0);
}

TEST(Fresnel, TotalInternalReflectionAboveCriticalAngle) {
  const double critical_sin = 1.0 / 1.5;
  const double cos_c = std::sqrt(1.0 - critical_sin * critical_sin);
  EXPECT_EQ(fresnel_dielectric(cos_c * 0.999, 1.5, 1.0), 1.0);
  EXPECT_LT(fresnel_dielectric(cos_c * 1.001, 1.5, 1.0), 1.0);
  EXPECT_LT(refracted_cos(cos_c * 0.999, 1.5, 1.0), 0.0);
}

TEST(Fresnel, GrazingIncidenceReflectsEverything) {
  EXPECT_NEAR(fresnel_dielectric(0.0, 1.0, 1.5), 1.0, 1e-15);
  EXPECT_NEAR(fresnel_dielectric(1e-9, 1.0, 1.5), 1.0, 1e-8);
}

TEST(Fresnel, ContinuousInAngle) {
  double prev = fresnel_dielectric(1.0, 1.0, 1.5);
  for (int i = 1; i <= 10000; ++i) {
    const double mu = 1.0 - i / 10000.0;
    const double r = fresnel_dielectric(mu, 1.0, 1.5);
    EXPECT_LT(std::abs(r - prev), 0.02) << "mu=" << mu;
    prev = r;
  }
}

TEST(Fresnel, RefractionKeepsUnitLengthAndSnell) {
  glm::dvec3 d{std::sin(0.7), 0.0, -std::cos(0.7)};
  ASSERT_TRUE(refract_through_plane(&d, 1.0, 1.4));
  EXPECT_NEAR(std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z), 1.0, 1e-15);
  EXPECT_NEAR(d.x * 1.4, std::sin(0.7), 1e-14);  // n_i sin_i = n_t sin_t
  EXPECT_LT(d.z, 0.0);
}

}  // namespace lamina

namespace lamina {

// An index-matched plane is no interface: the direction passes bit for bit, not renormalised
// (a walk's direction a rounding step off unit length stays as it is, as in a homogeneous layer).
TEST(Fresnel, IndexMatchedRefractionKeepsTheDirection) {
  const glm::dvec3 unit = glm::normalize(glm::dvec3(0.3, -0.5, -0.8));
  for (double scale : {1.0, 1.0 + 1e-13, 1.0 - 3e-14}) {
    glm::dvec3 d = unit * scale;
    const glm::dvec3 before = d;
    ASSERT_TRUE(refract_through_plane(&d, 1.4, 1.4));
    EXPECT_EQ(d.x, before.x);
    EXPECT_EQ(d.y, before.y);
    EXPECT_EQ(d.z, before.z);
  }
}

TEST(Fresnel, RefractedCosKeepsPrecisionAtGrazing) {
  // cos_t^2 = (1 - eta^2) + eta^2 cos_i^2 exactly; compare against that in long double for
  // grazing cosines, where 1 - eta^2 sin^2 would lose eps/cos^2 relative precision.
  for (double n_t : {1.0, 1.33, 1.5, 2.5}) {
    for (double c : {1e-3, 1e-6, 0.01745240643728351, 0.3, 1.0}) {
      const long double eta = 1.0L / n_t;
      const long double exact = std::sqrt((1.0L - eta * eta) + eta * eta * (long double)c * c);
      EXPECT_NEAR(refracted_cos(c, 1.0, n_t), (double)exact, 4e-16 * (double)exact) << n_t << " " << c;
    }
  }
  EXPECT_EQ(refracted_cos(1e-9, 1.4, 1.4), 1e-9);
}

}  // namespace lamina
