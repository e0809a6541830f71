#include "materials/phase/henyey_greenstein.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "materials/base/sampling.h"

namespace lamina {

TEST(HenyeyGreenstein, IsotropicAtZero) {
  EXPECT_NEAR(henyey_greenstein(0.3, 0.0), kInv4Pi, 1e-16);
}

TEST(HenyeyGreenstein, SamplerInvertsCdfForNegativeG) {
  // For g < 0 most mass is backwards: the median cosine must be negative.
  EXPECT_LT(sample_henyey_greenstein_cos(-0.5, 0.5), 0.0);
  EXPECT_GT(sample_henyey_greenstein_cos(0.5, 0.5), 0.0);
  // Endpoints of the CDF.
  EXPECT_NEAR(sample_henyey_greenstein_cos(-0.7, 0.0), -1.0, 1e-12);
  EXPECT_NEAR(sample_henyey_greenstein_cos(0.7, 1.0), 1.0, 1e-12);
}

TEST(HenyeyGreenstein, RotateAlongNormalIsFinite) {
  for (double z : {1.0, -1.0}) {
    const glm::dvec3 w = rotate_direction({0.0, 0.0, z}, 0.5, {std::cos(1.0), std::sin(1.0)});
    EXPECT_NEAR(w.x * w.x + w.y * w.y + w.z * w.z, 1.0, 1e-14);
    EXPECT_NEAR(w.z * z, 0.5, 1e-14);
  }
}

// rotate_direction keeps directions unit with one Newton step instead of a division by the
// length: over a million chained rotations (a walk's events) the length stays within 1e-14 of 1,
// and a direction 1e-7 too long comes back unit to 1e-13 (without the step it stays long).
TEST(HenyeyGreenstein, RotateKeepsDirectionsUnit) {
  Rng rng(31, 0);
  glm::dvec3 d{0.0, 0.6, 0.8};
  double worst = 0.0;
  for (int i = 0; i < 1000000; ++i) {
    d = sample_henyey_greenstein(d, 0.8, rng.uniform(), rng.uniform());
    worst = std::max(worst, std::abs(std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z) - 1.0));
  }
  EXPECT_LT(worst, 1e-14);
  const glm::dvec3 long_d = (1.0 + 1e-7) * glm::dvec3{0.48, 0.6, 0.64};
  const glm::dvec3 w = rotate_direction(long_d, 0.3, unit_circle(0.2));
  EXPECT_NEAR(std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z), 1.0, 1e-13);
}

}  // namespace lamina
