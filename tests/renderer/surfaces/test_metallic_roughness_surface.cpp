// glTF's metallic-roughness BRDF (renderer/surfaces/metallic_roughness_surface.h): chi-square of
// its sampler against its pdf, reciprocity, energy (the white metal at roughness 1 and normal
// incidence is the analytic 1 - ln 2 of GGX's masking loss; the dielectric stays below 1), and
// the metal lobe against materials' RoughConductor (itself checked against Mitsuba 3) with the
// Fresnel factor divided out.
#include <cmath>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/interfaces/microfacet.h"
#include "materials/base/sampling.h"
#include "renderer/surfaces/metallic_roughness_surface.h"
#include "tests/support/sphere_quadrature.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::Histogram;
using test::RunningStats;

glm::dvec3 from_angle(double theta_degrees) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t), 0.0, std::cos(t)};
}

struct Case {
  Spectrum base;
  double metallic, roughness, theta;
};
const Case kCases[] = {{Spectrum(0.8, 0.5, 0.2), 0.0, 0.5, 30.0}, {Spectrum(0.9, 0.6, 0.3), 1.0, 0.3, 60.0},
                       {Spectrum(0.5), 0.5, 0.7, 10.0}, {Spectrum(0.2, 0.7, 0.4), 0.0, 0.15, 75.0}};

TEST(MetallicRoughness, SamplerChiSquare) {
  const int n = 300000;
  int index = 0;
  for (const Case& c : kCases) {
    const MetallicRoughnessSurface s(c.base, c.metallic, c.roughness);
    const glm::dvec3 wo = from_angle(c.theta);
    Histogram h(40, 24);
    Rng rng(41, index++);
    for (int k = 0; k < n; ++k) {
      BsdfSample b;
      if (s.sample(wo, {rng.uniform(), rng.uniform()}, &b)) h.add(b.wi);
      else h.add_failure();
    }
    const auto r = test::chi_square_test(h.counts, h.expected([&](const glm::dvec3& wi) { return s.pdf(wo, wi); }, n));
    EXPECT_GT(r.p_value, 1e-4) << "case " << index - 1 << ": " << r.describe();
  }
}

TEST(MetallicRoughness, Reciprocal) {
  Rng rng(42, 0);
  for (const Case& c : kCases) {
    const MetallicRoughnessSurface s(c.base, c.metallic, c.roughness);
    for (int k = 0; k < 300; ++k) {
      const glm::dvec3 a = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
      const glm::dvec3 b = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
      const Spectrum fab = s.eval(a, b), fba = s.eval(b, a);
      for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(fab[ch], fba[ch], 1e-12 * (1.0 + fab[ch]));
    }
  }
}

TEST(MetallicRoughness, WhiteMetalFurnaceIsTheMaskingLoss) {
  // Base 1, metal: F = 1 everywhere, so the albedo is GGX's single-scattering energy: at alpha =
  // roughness^2 = 1 and normal incidence, 1 - ln 2 (test_microfacet.cpp derives it).
  const MetallicRoughnessSurface s(Spectrum(1.0), 1.0, 1.0);
  const glm::dvec3 wo(0.0, 0.0, 1.0);
  const double quadrature = test::integrate_sphere([&](const glm::dvec3& wi) { return s.eval(wo, wi)[0] * wi.z; }, true);
  EXPECT_NEAR(quadrature, 1.0 - std::log(2.0), 1e-6);
  RunningStats mc;
  Rng rng(43, 0);
  for (int k = 0; k < 200000; ++k) {
    BsdfSample b;
    mc.add(s.sample(wo, {rng.uniform(), rng.uniform()}, &b) ? b.f[0] * b.wi.z / b.pdf : 0.0);
  }
  EXPECT_TRUE(test::WithinKSigma(mc.mean(), quadrature, mc.standard_error()));
}

// The dielectric's albedo two ways: quadrature of eval and the sampler's weights. Below 1 at
// normal incidence; the model as glTF specifies it, (1 - F(wo.h)) diffuse + F specular, is not
// energy conserving at grazing views (Appendix B is "a simple model"; at 80 degrees and
// roughness 0.05 a white base reflects 1.35): kept as specified, documented.
TEST(MetallicRoughness, WhiteDielectricAlbedoTwoWays) {
  for (double roughness : {0.2, 0.5, 1.0})
    for (double theta : {0.0, 45.0, 80.0}) {
      const MetallicRoughnessSurface s(Spectrum(1.0), 0.0, roughness);
      const glm::dvec3 wo = from_angle(theta);
      const double albedo = test::integrate_sphere([&](const glm::dvec3& wi) { return s.eval(wo, wi)[0] * wi.z; }, true);
      RunningStats mc;
      Rng rng(45, static_cast<std::uint64_t>(roughness * 100 + theta));
      for (int k = 0; k < 100000; ++k) {
        BsdfSample b;
        mc.add(s.sample(wo, {rng.uniform(), rng.uniform()}, &b) ? b.f[0] * b.wi.z / b.pdf : 0.0);
      }
      EXPECT_TRUE(test::WithinKSigma(mc.mean(), albedo, mc.standard_error())) << roughness << " " << theta;
      if (theta == 0.0) {
        EXPECT_LT(albedo, 1.0) << roughness;
      }
    }
}

TEST(MetallicRoughness, MetalLobeIsTheRoughConductorsWithSchlick) {
  Rng rng(44, 0);
  const Spectrum base(0.9, 0.6, 0.3);
  for (double roughness : {0.2, 0.6, 1.0}) {
    const MetallicRoughnessSurface s(base, 1.0, roughness);
    RoughConductor c;
    c.distribution.alpha = roughness * roughness;
    c.eta = Spectrum(1.5);
    c.k = Spectrum(2.0);
    for (int k = 0; k < 300; ++k) {
      const glm::dvec3 wo = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
      const glm::dvec3 wi = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
      const glm::dvec3 h = glm::normalize(wo + wi);
      const Spectrum ours = s.eval(wo, wi) / fresnel_schlick(glm::dot(wo, h), base);
      const Spectrum theirs = c.eval(wo, wi) / fresnel_conductor(glm::dot(wo, h), c.eta, c.k);
      for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(ours[ch], theirs[ch], 1e-10 * (1.0 + theirs[ch]));
    }
  }
}

}  // namespace
}  // namespace lamina
