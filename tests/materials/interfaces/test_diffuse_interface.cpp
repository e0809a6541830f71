// The diffuse interface's formulas (materials/interfaces/diffuse_interface.h): its diffuse
// reflectance against the closed form of Stern (1964) that PROSPECT uses, and energy and
// reciprocity of its BSDF by independent quadrature.
#include "materials/interfaces/diffuse_interface.h"

#include <cmath>

#include <gtest/gtest.h>

#include "materials/interfaces/fresnel.h"
#include "materials/spectral/prospect.h"

namespace lamina {
namespace {

constexpr double kPi = 3.14159265358979323846;

// int_0^1 g(mu) mu dmu by the midpoint rule in x = mu^2 (an estimator apart from the code's
// graded Gauss panels); 1e6 cells: error below 1e-9 for the smooth integrands here.
template <class G>
double cosine_integral(G g) {
  constexpr int kCells = 1000000;
  double sum = 0.0;
  for (int i = 0; i < kCells; ++i) sum += g(std::sqrt((i + 0.5) / kCells));
  return 0.5 * sum / kCells;
}

TEST(DiffuseInterface, ReflectanceMatchesTheClosedForm) {
  for (double n : {1.05, 1.2, 1.33, 1.4, 1.5, 1.8, 2.5}) {
    // PROSPECT's tav(90, n): the hemispherical transmissivity from the light side, 1 - rbar_lo.
    EXPECT_NEAR(diffuse_fresnel_reflectance(1.0, n), 1.0 - average_transmissivity(90.0, n), 1e-12) << n;
    EXPECT_NEAR(diffuse_fresnel_reflectance(1.3, 1.3 * n), 1.0 - average_transmissivity(90.0, n), 1e-12) << n;
    // Stokes: from the dense side, 1 - rbar_hi = (1 - rbar_lo) / n^2 (total internal reflection included).
    EXPECT_NEAR(1.0 - diffuse_fresnel_reflectance(n, 1.0), (1.0 - diffuse_fresnel_reflectance(1.0, n)) / (n * n), 1e-12) << n;
  }
  EXPECT_EQ(diffuse_fresnel_reflectance(1.4, 1.4), 0.0);
}

TEST(DiffuseInterface, ConservesEnergyFromBothSides) {
  for (double n : {1.1, 1.45, 2.0}) {
    const DiffuseInterface d(n, 1.0);  // either order
    EXPECT_EQ(d.n_lo, 1.0);
    EXPECT_EQ(d.n_hi, n);
    // Light side at cosine mu: F specular + int f(lo->hi) mu_hi d(omega_hi) = F + (1 - F) = 1 for every mu.
    const double lambert = 2.0 * kPi * cosine_integral([](double) { return 1.0 / kPi; });  // int mu/pi d(omega)
    EXPECT_NEAR(lambert, 1.0, 1e-9);
    // Dense side, any direction: t_hi by integration of f(hi->lo) over the light side, plus 1 - t_hi
    // of the Lambertian reflection.
    const double t = 2.0 * kPi * cosine_integral([&](double mu) { return d.btdf_dense_to_light(mu); });
    EXPECT_NEAR(t, d.t_hi, 1e-9) << n;
    EXPECT_NEAR(t + 2.0 * kPi * cosine_integral([&](double) { return d.brdf_dense(); }), 1.0, 1e-9) << n;
    // The exit density integrates to 1.
    EXPECT_NEAR(2.0 * kPi * cosine_integral([&](double mu) { return d.exit_pdf(mu) / mu; }), 1.0, 1e-9) << n;
  }
}

TEST(DiffuseInterface, IsReciprocal) {
  // f(i -> o) / n_o^2 = f(o -> i) / n_i^2 for every pair of cosines.
  const DiffuseInterface d(1.0, 1.5);
  for (double mu_lo : {0.05, 0.3, 0.7, 1.0}) {
    EXPECT_NEAR(d.btdf_light_to_dense(mu_lo) / (1.5 * 1.5), d.btdf_dense_to_light(mu_lo) / 1.0, 1e-15);
    EXPECT_NEAR(d.btdf_light_to_dense(mu_lo), (1.0 - fresnel_dielectric(mu_lo, 1.0, 1.5)) / kPi, 1e-15);
  }
  // Stokes' t21 = tav(90, n) / n^2 of PROSPECT's plate.
  EXPECT_NEAR(d.t_hi, average_transmissivity(90.0, 1.5) / (1.5 * 1.5), 1e-12);
}


// Sampling against the formulas, by frequencies and means within 4 standard errors (2e5 samples,
// fixed seed): from the light side reflection with probability F and the specular direction, else
// a cosine-distributed direction beyond (mean cosine 2/3); from the dense side transmission with
// probability t_hi into directions of mean cosine int mu exit_pdf, else a cosine-distributed
// reflection.
TEST(DiffuseInterface, SamplingFollowsTheInterface) {
  const DiffuseInterface d(1.0, 1.5);
  constexpr int kN = 200000;
  const double mu_in = 0.3;
  const glm::dvec3 down{std::sqrt(1.0 - mu_in * mu_in), 0.0, -mu_in};
  Rng rng(7, 0);
  // Light side (above, light going down).
  int reflected = 0;
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < kN; ++i) {
    const glm::dvec3 w = d.sample(down, 1.0, rng);
    if (w.z > 0.0) {
      ++reflected;
      EXPECT_EQ(w, glm::dvec3(down.x, down.y, mu_in));
    } else {
      sum += -w.z;
      sum2 += w.z * w.z;
    }
  }
  const double F = fresnel_dielectric(mu_in, 1.0, 1.5);
  EXPECT_NEAR(static_cast<double>(reflected) / kN, F, 4.0 * std::sqrt(F * (1.0 - F) / kN));
  const int n_t = kN - reflected;
  const double mean = sum / n_t, se = std::sqrt((sum2 / n_t - mean * mean) / n_t);
  EXPECT_NEAR(mean, 2.0 / 3.0, 4.0 * se);
  // Dense side (below, light going up).
  const glm::dvec3 up{down.x, 0.0, mu_in};
  int transmitted = 0;
  double t_sum = 0.0, t_sum2 = 0.0, r_sum = 0.0, r_sum2 = 0.0;
  for (int i = 0; i < kN; ++i) {
    const glm::dvec3 w = d.sample(up, 1.5, rng);
    if (w.z > 0.0) {
      ++transmitted;
      t_sum += w.z;
      t_sum2 += w.z * w.z;
    } else {
      r_sum += -w.z;
      r_sum2 += w.z * w.z;
    }
  }
  EXPECT_NEAR(static_cast<double>(transmitted) / kN, d.t_hi, 4.0 * std::sqrt(d.t_hi * (1.0 - d.t_hi) / kN));
  const double exit_mean = 2.0 * kPi * cosine_integral([&](double mu) { return d.exit_pdf(mu); });  // int mu p dw
  const double t_mean = t_sum / transmitted, t_se = std::sqrt((t_sum2 / transmitted - t_mean * t_mean) / transmitted);
  EXPECT_NEAR(t_mean, exit_mean, 4.0 * t_se);
  const int n_r = kN - transmitted;
  const double r_mean = r_sum / n_r, r_se = std::sqrt((r_sum2 / n_r - r_mean * r_mean) / n_r);
  EXPECT_NEAR(r_mean, 2.0 / 3.0, 4.0 * r_se);
  // Deterministic in the rng.
  Rng a(3, 9), b(3, 9);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(d.sample(up, 1.5, a), d.sample(up, 1.5, b));
}

}  // namespace
}  // namespace lamina
