// The Monte Carlo walk's single-scattering part against the analytic first order
// (materials/analytic/first_order, written independently on the `analytic` branch): two derivations of
// the same physics that must agree. Index-matched and mismatched, transmitting, Lambert
// substrate, semi-infinite; several incidence angles.
#include <cmath>

#include <gtest/gtest.h>

#include "materials/brdf/brdf_table.h"
#include "materials/analytic/first_order.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

std::vector<LayerStack> stacks() {
  std::vector<LayerStack> out;
  auto one = [](double above, double n, double below, double t, Spectrum sa, Spectrum ss, Spectrum g) {
    LayerStack s;
    s.above_ior = above;
    s.layers.push_back(make_layer("a", n, t, sa, ss, g));
    s.below.ior = below;
    return s;
  };
  out.push_back(one(1.0, 1.0, 1.0, 0.3, Spectrum(0.5), Spectrum(3.0), Spectrum(0.6)));           // index-matched
  out.push_back(one(1.0, 1.5, 1.0, 0.3, Spectrum(0.5, 1.0, 2.0), Spectrum(3.0), Spectrum(-0.3))); // mismatched
  out.push_back(one(1.0, 1.33, 1.2, 0.2, Spectrum(1.0), Spectrum(2.0, 4.0, 1.0), Spectrum(0.8, 0.2, 0.0)));
  LayerStack two = one(1.0, 1.4, 1.0, 0.1, Spectrum(0.3), Spectrum(5.0), Spectrum(0.4));
  two.layers.push_back(make_layer("b", 1.2, 0.4, Spectrum(0.2), Spectrum(2.0), Spectrum(-0.5)));
  out.push_back(two);
  LayerStack lam = one(1.0, 1.3, 1.0, 0.2, Spectrum(0.5), Spectrum(2.0), Spectrum(0.3));
  lam.below.kind = Below::Kind::Lambert;
  lam.below.albedo = Spectrum(0.9, 0.5, 0.1);
  out.push_back(lam);
  out.push_back(one(1.0, 1.5, 1.0, kInfiniteThickness, Spectrum(1.0), Spectrum(3.0), Spectrum(0.5)));
  return out;
}

// Bins: per-photon values are W / Omega_proj with W <= 3 (spectral MIS bound; roulette cannot
// act before the first event's weight falls below 0.01), so Var <= 3 V / Omega_proj and
// sqrt(3 V / (Omega_proj N)) bounds the standard error where the sample one is unreliable
// (rare bins). The analytic bin average is a 6x6 quadrature: its error is checked against 10x10.
TEST(BrdfTableVsFirstOrder, SingleScatteringBins) {
  const std::uint64_t n = 20000;
  int compared = 0;
  for (const LayerStack& s : stacks()) {
    for (double theta : {0.0, 45.0, 75.0}) {
      BrdfOptions o;
      o.theta_i_deg = theta;
      o.phi_i_deg = 20.0;
      o.samples = n;
      o.bins_theta = 4;
      o.bins_phi = 4;
      o.seed = 17;
      const BrdfTable mc = brdf_table_monte_carlo(s, o);
      const BrdfTable fo = brdf_table_first_order(s, o, 6);
      const BrdfTable fo10 = brdf_table_first_order(s, o, 10);
      for (std::size_t b = 0; b < mc.value.size(); ++b) {
        const int k = (static_cast<int>(b) / o.bins_phi) % o.bins_theta;
        for (int c = 0; c < kChannels; ++c) {
          const double v = fo.single[b][c];
          const double quad = std::abs(fo10.single[b][c] - v);
          const double se = std::max(mc.single_stderr[b][c], std::sqrt(3.0 * v / (mc.projected_solid_angle(k) * n)));
          EXPECT_TRUE(test::WithinKSigma(mc.single[b][c], v, se, 4.0, 2.0 * quad + 1e-12))
              << "stack " << s.layers[0].ior << "/" << s.layers.size() << " theta " << theta << " bin " << b
              << " channel " << c;
          ++compared;
        }
      }
    }
  }
  EXPECT_GT(compared, 500);
}

// Point values: the connection estimator restricted to first-order events estimates exactly
// first_order_bsdf(wi, wo), without binning or quadrature.
TEST(BrdfTableVsFirstOrder, SingleScatteringPointValues) {
  for (const LayerStack& s : stacks()) {
    for (double theta : {0.0, 60.0}) {
      const glm::dvec3 wi = incident_direction(theta, 0.0);
      std::vector<glm::dvec3> wo = {incident_direction(30.0, 0.0), incident_direction(70.0, 135.0),
                                    incident_direction(10.0, 250.0)};
      if (s.transmits()) {
        wo.push_back(-incident_direction(20.0, 180.0));
        wo.push_back(-incident_direction(65.0, 40.0));
      }
      const std::vector<PointEstimate> est = brdf_connection_estimate(s, wi, wo, 8000, 23);
      for (std::size_t j = 0; j < wo.size(); ++j) {
        const Spectrum f = first_order_bsdf(s, wi, wo[j]);
        for (int c = 0; c < kChannels; ++c)
          EXPECT_TRUE(test::WithinKSigma(est[j].single.value[c], f[c], est[j].single.stderr_[c], 4.0, 1e-12))
              << "stack " << s.layers[0].ior << "/" << s.layers.size() << " theta " << theta << " wo " << j
              << " channel " << c;
      }
    }
  }
}

}  // namespace
}  // namespace lamina
