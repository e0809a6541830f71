// The energy-conserving rough dielectric (materials/interfaces/microsurface.h, Heitz et al. 2016):
// its walks lose nothing; their first order against the closed form (chi-square of the sampled
// directions against the density integrated over bins by quadrature, independently of the
// sampler); the orders beyond against the next-event estimate (an independent estimator of the
// same density); reciprocity of the BSDF estimate; the smooth limit; the single-scattering
// model of microfacet.h as its first order.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/interfaces/fresnel.h"
#include "materials/interfaces/microfacet.h"
#include "materials/interfaces/microsurface.h"
#include "materials/interfaces/microsurface_first_order.h"
#include "materials/base/sampling.h"
#include "tests/support/sphere_quadrature.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::chi_square_test;
using test::Histogram;
using test::integrate_sphere;
using test::RunningStats;

glm::dvec3 from_angle(double theta_degrees, double side = 1.0) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t), 0.0, side * std::cos(t)};
}

struct Case {
  double alpha, theta, side;
};
const std::vector<Case> kCases = {{0.1, 30.0, 1.0}, {0.3, 0.0, 1.0}, {0.6, 60.0, 1.0}, {1.0, 75.0, 1.0},
                                  {0.3, 20.0, -1.0}, {0.6, 50.0, -1.0}, {1.0, 80.0, -1.0}};

TEST(Microsurface, WalksLoseNothing) {
  // Every walk leaves the microsurface (weight 1 by construction): the interface's reflectance
  // plus transmittance is exactly 1, the loss of the single-scattering model is gone.
  int case_index = 0;
  for (const Case& c : kCases) {
    const MicrosurfaceDielectric s{{c.alpha}, 1.0, 1.5};
    Rng rng(5, case_index++);
    int failed = 0, max_order = 0;
    for (int k = 0; k < 100000; ++k) {
      glm::dvec3 to;
      int order = 0;
      if (!s.sample(from_angle(c.theta, c.side), rng, &to, &order)) ++failed;
      max_order = std::max(max_order, order);
      ASSERT_NEAR(glm::length(to), 1.0, 1e-9);
    }
    EXPECT_EQ(failed, 0) << c.alpha << " " << c.theta << " " << c.side;
    EXPECT_LT(max_order, 64) << c.alpha;
  }
}

TEST(Microsurface, FirstOrderOfTheWalksMatchesTheClosedForm) {
  // Chi-square: the directions of the walks of one scattering against density_single integrated
  // over each bin; the walks of more scatterings go to the last bin, expected n (1 - integral).
  const int n = 200000;
  int case_index = 0;
  for (const Case& c : {kCases[0], kCases[3], kCases[4], kCases[6]}) {
    const MicrosurfaceDielectric s{{c.alpha}, 1.0, 1.5};
    const glm::dvec3 from = from_angle(c.theta, c.side);
    Histogram h(24, 12);
    Rng rng(6, case_index++);
    for (int k = 0; k < n; ++k) {
      glm::dvec3 to;
      int order = 0;
      if (s.sample(from, rng, &to, &order) && order == 1) h.add(to);
      else h.add_failure();
    }
    const auto r = chi_square_test(h.counts, h.expected([&](const glm::dvec3& to) { return s.density_single(from, to); }, n));
    EXPECT_GT(r.p_value, 1e-4) << c.alpha << " " << c.theta << " " << c.side << ": " << r.describe();
  }
}

TEST(Microsurface, ChiSquareRejectsTheSingleScatteringMaskingForTransmission) {
  // The test above can fail: the first order with microfacet.h's G2 = 1/(1 + Lambda + Lambda) for
  // transmission (not the Beta function the height-correlated walk implies) is rejected.
  const int n = 200000;
  const MicrosurfaceDielectric s{{1.0}, 1.0, 1.5};
  const RoughDielectric ss{{1.0}, 1.0, 1.5};
  const glm::dvec3 from = from_angle(75.0);
  Histogram h(32, 16);
  Rng rng(7, 0);
  for (int k = 0; k < n; ++k) {
    glm::dvec3 to;
    int order = 0;
    if (s.sample(from, rng, &to, &order) && order == 1) h.add(to);
    else h.add_failure();
  }
  // RoughDielectric::eval(to, from) |to.z| is its density of `to` (microfacet.h).
  const auto r = chi_square_test(h.counts, h.expected([&](const glm::dvec3& to) { return ss.eval(to, from) * std::abs(to.z); }, n));
  EXPECT_LT(r.p_value, 1e-6) << r.describe();
}

TEST(Microsurface, HigherOrdersMatchTheNextEventEstimate) {
  // The fraction of walks of two or more scatterings, against the integral over the sphere of
  // density - density_single (next-event estimates, directions uniform on the sphere): two
  // independent estimators of the same number, compared within 4 combined standard errors.
  int case_index = 0;
  for (const Case& c : kCases) {
    if (c.alpha < 0.6) continue;  // the multiple scattering is tiny, its estimate all noise
    const MicrosurfaceDielectric s{{c.alpha}, 1.0, 1.5};
    const glm::dvec3 from = from_angle(c.theta, c.side);
    Rng rng(8, case_index++);
    RunningStats walks, nee;
    for (int k = 0; k < 200000; ++k) {
      glm::dvec3 to;
      int order = 0;
      s.sample(from, rng, &to, &order);
      walks.add(order >= 2 ? 1.0 : 0.0);
      const glm::dvec3 u = sample_uniform_sphere({rng.uniform(), rng.uniform()});
      nee.add((s.density(from, u, rng) - s.density_single(from, u)) * 4.0 * kPi);
    }
    const double se = std::hypot(walks.standard_error(), nee.standard_error());
    EXPECT_NEAR(walks.mean(), nee.mean(), 4.0 * se) << c.alpha << " " << c.theta << " " << c.side;
    EXPECT_GT(walks.mean(), 5.0 * se) << "the case must have measurable multiple scattering";
  }
}

TEST(Microsurface, BsdfIsReciprocal) {
  // f(wo, wi) / n(wo)^2 = f(wi, wo) / n(wi)^2, reflection on both sides and transmission both
  // ways, from the means of independent estimates (each eval is one walk from its own wi).
  const std::vector<std::pair<glm::dvec3, glm::dvec3>> pairs = {
      {from_angle(30.0), glm::normalize(glm::dvec3(-0.4, 0.3, 0.8))},
      {from_angle(70.0), glm::normalize(glm::dvec3(0.2, -0.5, -0.6))},
      {from_angle(40.0, -1.0), glm::normalize(glm::dvec3(-0.7, 0.1, -0.3))},
      {from_angle(10.0, -1.0), glm::normalize(glm::dvec3(0.1, 0.6, 0.5))}};
  int case_index = 0;
  for (double alpha : {0.3, 1.0})
    for (const auto& [a, b] : pairs) {
      const MicrosurfaceDielectric s{{alpha}, 1.0, 1.5};
      auto n_of = [&](const glm::dvec3& w) { return w.z > 0.0 ? s.n_above : s.n_below; };
      Rng rng(9, case_index++);
      RunningStats ab, ba;
      for (int k = 0; k < 100000; ++k) {
        ab.add(s.eval(a, b, rng) / (n_of(a) * n_of(a)));
        ba.add(s.eval(b, a, rng) / (n_of(b) * n_of(b)));
      }
      const double se = std::hypot(ab.standard_error(), ba.standard_error());
      EXPECT_NEAR(ab.mean(), ba.mean(), 4.0 * se) << alpha << " " << a.z << " " << b.z;
      EXPECT_GT(ab.mean(), 5.0 * se);
    }
}

TEST(Microsurface, FirstOrderReflectionIsTheSingleScatteringModel) {
  // Same G2 for reflection: microfacet.h's RoughDielectric is the first order, exactly.
  for (double alpha : {0.1, 0.5, 1.0}) {
    const MicrosurfaceDielectric s{{alpha}, 1.0, 1.5};
    const RoughDielectric ss{{alpha}, 1.0, 1.5};
    for (const auto& [wo, wi] : {std::pair{from_angle(20.0), glm::normalize(glm::dvec3(-0.3, 0.2, 0.9))},
                                 std::pair{from_angle(60.0, -1.0), glm::normalize(glm::dvec3(-0.5, 0.1, -0.7))}})
      EXPECT_NEAR(s.eval_single(wo, wi), ss.eval(wo, wi), 1e-12 * ss.eval(wo, wi)) << alpha;
  }
}

TEST(Microsurface, SmoothLimitReflectsFresnel) {
  // alpha -> 0: the fraction of walks that reflect is the smooth Fresnel reflectance, from
  // either side (total internal reflection from below beyond the critical angle).
  int case_index = 0;
  for (const auto& [theta, side] : {std::pair{0.0, 1.0}, {45.0, 1.0}, {75.0, 1.0}, {30.0, -1.0}, {50.0, -1.0}}) {
    const MicrosurfaceDielectric s{{0.002}, 1.0, 1.5};
    const glm::dvec3 from = from_angle(theta, side);
    const double expected = fresnel_dielectric(from.z, side > 0 ? 1.0 : 1.5, side > 0 ? 1.5 : 1.0);
    Rng rng(10, case_index++);
    RunningStats reflected;
    for (int k = 0; k < 100000; ++k) {
      glm::dvec3 to;
      s.sample(from, rng, &to);
      reflected.add(to.z * from.z > 0.0 ? 1.0 : 0.0);
    }
    EXPECT_NEAR(reflected.mean(), expected, 4.0 * reflected.standard_error() + 2e-3) << theta << " " << side;
  }
}

TEST(Microsurface, InterfaceValueForProjection) {
  // rough_interface_bsdf: the single-scattering model is RoughDielectric::eval; the energy-
  // conserving one is deterministic for a query and above its first order (the orders beyond add).
  const glm::dvec3 wo = from_angle(40.0), wi = glm::normalize(glm::dvec3(0.5, 0.2, -0.6));
  EXPECT_EQ(rough_interface_bsdf(InterfaceModel::SingleScattering, 0.5, 1.0, 1.4, wo, wi),
            (RoughDielectric{{0.5}, 1.0, 1.4}.eval(wo, wi)));
  const double a = rough_interface_bsdf(InterfaceModel::EnergyConserving, 0.8, 1.0, 1.4, wo, wi, 256);
  EXPECT_EQ(a, rough_interface_bsdf(InterfaceModel::EnergyConserving, 0.8, 1.0, 1.4, wo, wi, 256));
  EXPECT_GT(a, (MicrosurfaceDielectric{{0.8}, 1.0, 1.4}.eval_single(wo, wi)));
}

TEST(Microsurface, FirstOrderPerDirectionIsTheClosedForm) {
  // MicrosurfaceFirstOrder (one `from`, many `to`, its Beta function reused while Lambda(to)
  // repeats) gives the numbers of a fresh evaluation per query bit for bit, over azimuth sweeps
  // at fixed polar angles (where Lambda(to) repeats up to rounding) in reflection and
  // transmission, from both sides; and its transmission is Walter's with the Beta function's
  // masking in place of G2 (Heitz 2014, eq. 101): f = f_G2 (1 + La + Lb) B(1 + La, 1 + Lb).
  int transmissions = 0;
  for (double alpha : {0.05, 0.4, 1.0})
    for (const auto& [theta, side] : {std::pair{0.0, 1.0}, {35.0, 1.0}, {80.0, 1.0}, {25.0, -1.0}, {60.0, -1.0}}) {
      const MicrosurfaceDielectric s{{alpha}, 1.0, 1.45};
      const RoughDielectric ss{{alpha}, 1.0, 1.45};
      const glm::dvec3 from = from_angle(theta, side);
      MicrosurfaceFirstOrder first(s, from);
      for (double to_theta : {0.0, 10.0, 40.0, 70.0, 89.0, 90.0, 100.0, 140.0, 170.0, 180.0})
        for (int k = 0; k < 24; ++k) {
          const double t = to_theta * kPi / 180.0, phi = 2.0 * kPi * (k + 0.37) / 24.0;
          const glm::dvec3 to{std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t)};
          const double f = first.eval(to);
          EXPECT_EQ(first.density(to), MicrosurfaceFirstOrder(s, from).density(to)) << alpha << " " << theta;
          EXPECT_EQ(f, MicrosurfaceFirstOrder(s, from).eval(to));
          EXPECT_EQ(f, s.eval_single(to, from));
          if (to.z * from.z < 0.0 && std::abs(to.z) > 1e-3 && f > 0.0) {  // RoughDielectric cuts grazing
            const double la = s.distribution.lambda(from), lb = s.distribution.lambda(to);
            const double beta = std::exp(std::lgamma(1.0 + la) + std::lgamma(1.0 + lb) - std::lgamma(2.0 + la + lb));
            EXPECT_NEAR(f, ss.eval(to, from) * (1.0 + la + lb) * beta, 1e-12 * f) << alpha << " " << theta;
            ++transmissions;
          }
        }
    }
  EXPECT_GT(transmissions, 500);
}

}  // namespace
}  // namespace lamina
