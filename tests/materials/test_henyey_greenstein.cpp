#include "materials/henyey_greenstein.h"

#include <cmath>

#include <gtest/gtest.h>

#include "materials/sampling.h"

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

}  // namespace lamina
