#include "materials/sampling.h"

#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>

namespace lamina {

// unit_circle(u) against cos and sin of 2 pi u in long double (64-bit mantissa: in double the
// reference's own argument 2 pi u is rounded by up to 4.4e-16 near u = 1, more than unit_circle,
// whose reduction is exact), at the quadrant and octant boundaries (where the reduction switches
// k) and at a million uniforms of the generator. The bound, 4e-16, is four rounding units of a
// value of magnitude 1 (the argument 2 pi r is rounded once, the polynomials a few times); an
// error of the truncated series or of a quadrant is 1e-16 to 1 and fails it.
TEST(Sampling, UnitCircleMatchesTheLibraryToRounding) {
  double worst = 0.0;
  auto check = [&](double u) {
    const glm::dvec2 a = unit_circle(u);
    const long double x = 2.0L * 3.14159265358979323846264338327950288L * static_cast<long double>(u);
    const double error = static_cast<double>(
        std::max(std::abs(a.x - std::cos(x)), std::abs(a.y - std::sin(x))));
    worst = std::max(worst, error);
    ASSERT_LE(error, 4e-16) << "u " << u;
  };
  for (int k = 0; k <= 8; ++k)
    for (double e : {-1e-16, 0.0, 1e-16, -1e-9, 1e-9}) {
      const double u = k / 8.0 + e;
      if (u >= 0.0 && u <= 1.0) check(u);
    }
  Rng rng(12, 0);
  for (int i = 0; i < 1000000; ++i) check(rng.uniform());
  std::printf("unit_circle: worst difference from cos/sin in long double %.3g\n", worst);
}

}  // namespace lamina
