// The GGX microfacet model (materials/interfaces/microfacet.h): the normalisations that define D and the
// visible-normal density, chi-square tests of the visible-normal and rough-dielectric samplers
// against their densities integrated over bins by quadrature (independently of the samplers),
// the sample weights against eval/pdf, reciprocity of the rough dielectric BSDF, and
// white-furnace tests: the single-scattering energy of the lobes from the sampler's weights
// against the same from quadrature of eval, with the loss growing with roughness and vanishing
// in the smooth limit.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/interfaces/fresnel.h"
#include "materials/interfaces/microfacet.h"
#include "materials/base/sampling.h"
#include "tests/support/sphere_quadrature.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::chi_square_test;
using test::direction;
using test::Histogram;
using test::integrate_sphere;
using test::RunningStats;

glm::dvec3 from_angle(double theta_degrees) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t), 0.0, std::cos(t)};
}

TEST(Microfacet, DistributionIsNormalised) {
  // integral D(m) m.z d(omega_m) = 1: the projected microfacet area is the macro area.
  for (double alpha : {0.05, 0.2, 0.5, 1.0}) {
    GgxDistribution d{alpha};
    EXPECT_NEAR(integrate_sphere([&](const glm::dvec3& m) { return d.d(m) * m.z; }, true), 1.0, 1e-5)
        << alpha;
  }
}

TEST(Microfacet, VisibleNormalDensityIsNormalised) {
  // integral G1(wo) max(0, wo.m) D(m) dm = wo.z (Heitz 2014 eq. 18): the visible density
  // integrates to 1, on either side of the surface.
  for (double alpha : {0.1, 0.5, 1.0})
    for (double theta : {0.0, 30.0, 60.0, 85.0})
      for (double side : {1.0, -1.0}) {
        GgxDistribution d{alpha};
        glm::dvec3 wo = from_angle(theta);
        wo.z *= side;
        const double total = integrate_sphere([&](const glm::dvec3& m) {
          return d.visible_pdf(wo, side > 0 ? m : glm::dvec3(m.x, m.y, -m.z));
        }, true);
        EXPECT_NEAR(total, 1.0, 1e-5) << alpha << " " << theta << " " << side;
      }
}

TEST(Microfacet, VisibleNormalSamplerChiSquare) {
  const int n = 200000;
  int case_index = 0;
  for (double alpha : {0.15, 0.5, 1.0})
    for (double theta : {0.0, 45.0, 80.0}) {
      GgxDistribution d{alpha};
      const glm::dvec3 wo = from_angle(theta);
      Histogram h(40, 24);
      Rng rng(11, case_index++);
      for (int k = 0; k < n; ++k) h.add(d.sample_visible(wo, {rng.uniform(), rng.uniform()}));
      const auto r = chi_square_test(h.counts, h.expected([&](const glm::dvec3& m) { return d.visible_pdf(wo, m); }, n));
      EXPECT_GT(r.p_value, 1e-4) << "alpha " << alpha << " theta " << theta << ": " << r.describe();
    }
}

TEST(Microfacet, ChiSquareRejectsAVisibleNormalSamplerOfTheWrongRoughness) {
  const int n = 200000;
  GgxDistribution d{0.5}, wrong{0.45};
  const glm::dvec3 wo = from_angle(45.0);
  Histogram h(40, 24);
  Rng rng(12, 0);
  for (int k = 0; k < n; ++k) h.add(wrong.sample_visible(wo, {rng.uniform(), rng.uniform()}));
  EXPECT_LT(chi_square_test(h.counts, h.expected([&](const glm::dvec3& m) { return d.visible_pdf(wo, m); }, n)).p_value,
            1e-6);
}

struct DielectricCase {
  double alpha, n_above, n_below, theta;
  bool from_below;
};
const DielectricCase kDielectricCases[] = {
    {0.3, 1.0, 1.4, 30.0, false}, {0.7, 1.0, 1.4, 70.0, false}, {0.3, 1.0, 1.4, 30.0, true},
    {0.5, 1.0, 1.4, 60.0, true},  {0.5, 1.33, 1.0, 20.0, false}, {1.0, 1.0, 1.5, 0.0, false},
};

glm::dvec3 case_wo(const DielectricCase& c) {
  glm::dvec3 wo = from_angle(c.theta);
  if (c.from_below) wo.z = -wo.z;
  return wo;
}

TEST(Microfacet, RoughDielectricSamplerChiSquare) {
  // Both lobes at once over the whole sphere; the samples lost below the surface (single
  // scattering) are the last bin, expected 1 - integral of pdf.
  const int n = 300000;
  int case_index = 0;
  for (const DielectricCase& c : kDielectricCases) {
    const RoughDielectric bsdf{{c.alpha}, c.n_above, c.n_below};
    const glm::dvec3 wo = case_wo(c);
    Histogram h(48, 24);
    Rng rng(13, case_index++);
    for (int k = 0; k < n; ++k) {
      const auto s = bsdf.sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform());
      if (s.weight > 0.0) h.add(s.wi);
      else h.add_failure();
    }
    const auto r = chi_square_test(h.counts, h.expected([&](const glm::dvec3& wi) { return bsdf.pdf(wo, wi); }, n));
    EXPECT_GT(r.p_value, 1e-4) << "case " << case_index - 1 << ": " << r.describe();
  }
}

TEST(Microfacet, RoughConductorSamplerChiSquare) {
  const int n = 200000;
  int case_index = 0;
  for (double alpha : {0.1, 0.5, 1.0})
    for (double theta : {10.0, 70.0}) {
      RoughConductor metal;
      metal.distribution.alpha = alpha;
      const glm::dvec3 wo = from_angle(theta);
      Histogram h(40, 24);
      Rng rng(18, case_index++);
      for (int k = 0; k < n; ++k) {
        glm::dvec3 wi;
        if (metal.sample(wo, {rng.uniform(), rng.uniform()}, &wi)) h.add(wi);
        else h.add_failure();
      }
      const auto r = chi_square_test(h.counts, h.expected([&](const glm::dvec3& wi) { return metal.pdf(wo, wi); }, n));
      EXPECT_GT(r.p_value, 1e-4) << "alpha " << alpha << " theta " << theta << ": " << r.describe();
    }
}

TEST(Microfacet, RoughDielectricWeightsAgreeWithEvalAndPdf) {
  Rng rng(14, 0);
  for (const DielectricCase& c : kDielectricCases) {
    const RoughDielectric bsdf{{c.alpha}, c.n_above, c.n_below};
    const glm::dvec3 wo = case_wo(c);
    for (int k = 0; k < 2000; ++k) {
      const auto s = bsdf.sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform());
      if (!(s.weight > 0.0)) continue;
      const double expected = bsdf.eval(wo, s.wi) * std::abs(s.wi.z) / bsdf.pdf(wo, s.wi);
      ASSERT_NEAR(s.weight, expected, 1e-9 * expected) << c.alpha << " " << c.theta;
      ASSERT_NEAR(s.pdf, bsdf.pdf(wo, s.wi), 1e-12 * s.pdf);
      // Power mode: the refraction's weight without the n^2 law.
      const auto p = bsdf.sample(wo, {0.3, 0.6}, 0.99, true);
      const auto q = bsdf.sample(wo, {0.3, 0.6}, 0.99, false);
      if (!p.reflected && p.weight > 0.0) {
        const double n_o = bsdf.index_of(wo), n_i = bsdf.index_of(p.wi);
        ASSERT_NEAR(q.weight, p.weight * n_o * n_o / (n_i * n_i), 1e-12);
      }
    }
  }
}

TEST(Microfacet, RoughDielectricIsReciprocal) {
  // f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2 (generalised reciprocity of the radiance BSDF, n_o the
  // index on wo's side; Veach's thesis eq. 5.28).
  Rng rng(15, 0);
  for (double alpha : {0.1, 0.4, 1.0})
    for (int k = 0; k < 500; ++k) {
      const RoughDielectric bsdf{{alpha}, 1.0, 1.45};
      const glm::dvec3 a = sample_uniform_sphere({rng.uniform(), rng.uniform()});
      const glm::dvec3 b = sample_uniform_sphere({rng.uniform(), rng.uniform()});
      const double fab = bsdf.eval(a, b) / std::pow(bsdf.index_of(a), 2);
      const double fba = bsdf.eval(b, a) / std::pow(bsdf.index_of(b), 2);
      ASSERT_NEAR(fab, fba, 1e-10 * std::max(fab, 1e-300)) << alpha;
    }
}

TEST(Microfacet, WhiteFurnaceEnergyOfTheRoughDielectric) {
  // The power that leaves after one microfacet interaction: E[power weight] over samples from
  // wo, against integral f |cos| d(omega) by quadrature with the n^2 law undone for the
  // refracted part (independent code: eval against the sampler). It is below 1 by the
  // single-scattering loss, which vanishes as alpha -> 0 and grows with alpha.
  double previous_loss = -1.0;
  for (double alpha : {0.01, 0.2, 0.5, 1.0}) {
    const RoughDielectric bsdf{{alpha}, 1.0, 1.5};
    const glm::dvec3 wo = from_angle(60.0);
    RunningStats mc;
    Rng rng(16, static_cast<std::uint64_t>(alpha * 100));
    for (int k = 0; k < 400000; ++k) mc.add(bsdf.sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform(), true).weight);
    const double quadrature = integrate_sphere([&](const glm::dvec3& wi) {
      const double n_i = bsdf.index_of(wi), n_o = bsdf.index_of(wo);
      const double power = wi.z * wo.z < 0.0 ? (n_i * n_i) / (n_o * n_o) : 1.0;
      return bsdf.eval(wo, wi) * std::abs(wi.z) * power;
    });
    EXPECT_TRUE(test::WithinKSigma(mc.mean(), quadrature, mc.standard_error(), 4.0, 2e-3)) << alpha;
    const double loss = 1.0 - mc.mean();
    EXPECT_LT(mc.mean(), 1.0 + 4 * mc.standard_error());
    if (alpha == 0.01) {
      EXPECT_LT(loss, 1e-3);
    } else {
      EXPECT_GT(loss, previous_loss);
    }
    previous_loss = loss;
  }
}

TEST(Microfacet, WhiteFurnaceOfAPerfectConductor) {
  // F = 1 (k huge): the albedo is the masking loss alone, E[G2/G1] over visible normals;
  // quadrature of eval |cos| gives the same. At alpha = 1 and normal incidence it is analytic:
  // D = 1/pi, so the visible normals are cosine distributed; wi = reflect(z, m) has
  // theta_i = 2 theta_m (lost below for theta_m > 45 degrees) and G2 = 1 / (1 + Lambda(wi)) =
  // 2 c / (1 + c) with c = cos theta_i; with x = cos 2 theta_m,
  // E = int_0^1 x / (1 + x) dx = 1 - ln 2 = 0.3069.
  for (double alpha : {0.05, 0.5, 1.0}) {
    RoughConductor metal;
    metal.distribution.alpha = alpha;
    metal.eta = Spectrum(1.0);
    metal.k = Spectrum(1e6);
    const glm::dvec3 wo = from_angle(0.0);
    RunningStats mc;
    Rng rng(17, static_cast<std::uint64_t>(alpha * 100));
    for (int k = 0; k < 200000; ++k) {
      glm::dvec3 wi;
      if (!metal.sample(wo, {rng.uniform(), rng.uniform()}, &wi)) {
        mc.add(0.0);
        continue;
      }
      mc.add(metal.eval(wo, wi)[0] * wi.z / metal.pdf(wo, wi));
    }
    const double quadrature = integrate_sphere([&](const glm::dvec3& wi) { return metal.eval(wo, wi)[0] * wi.z; }, true);
    EXPECT_TRUE(test::WithinKSigma(mc.mean(), quadrature, mc.standard_error(), 4.0, 2e-3)) << alpha;
    if (alpha == 1.0) {
      EXPECT_NEAR(quadrature, 1.0 - std::log(2.0), 1e-6);
    }
    if (alpha == 0.05) {
      EXPECT_LT(1.0 - quadrature, 5e-3);
    }
  }
}

TEST(Microfacet, ConductorFresnelLimits) {
  // A conductor of k = 0 is a dielectric; Schlick is exact at 0 and 90 degrees.
  for (double c : {1.0, 0.7, 0.2}) {
    EXPECT_NEAR(fresnel_conductor(c, Spectrum(1.5), Spectrum(0.0))[0], fresnel_dielectric(c, 1.0, 1.5), 1e-12);
  }
  const Spectrum gold_eta{0.143, 0.374, 1.442}, gold_k{3.983, 2.385, 1.603};
  const Spectrum f0 = fresnel_conductor(1.0, gold_eta, gold_k);
  for (int ch = 0; ch < 3; ++ch) {
    const double e = gold_eta[ch], k = gold_k[ch];
    EXPECT_NEAR(f0[ch], ((e - 1) * (e - 1) + k * k) / ((e + 1) * (e + 1) + k * k), 1e-12);
  }
  EXPECT_NEAR(fresnel_conductor(1e-9, gold_eta, gold_k)[0], 1.0, 1e-6);
  EXPECT_NEAR(fresnel_schlick(1.0, Spectrum(0.04))[1], 0.04, 1e-15);
  EXPECT_NEAR(fresnel_schlick(0.0, Spectrum(0.04))[1], 1.0, 1e-15);
}

}  // namespace
}  // namespace lamina
