// Unscattered transport: energy closure, closed forms for a slab, an independent bounce-by-bounce
// summation, and the limits (index ratio 1, tau = 0 and infinite, TIR, grazing).
#include "materials/analytic/zeroth_order.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "materials/interfaces/fresnel.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

Layer slab(double ior, double thickness, Spectrum sigma_a, Spectrum sigma_s = Spectrum(0.0)) {
  return make_layer("slab", ior, thickness, sigma_a, sigma_s, Spectrum(0.3));
}

using test::stack_of;

std::vector<LayerStack> assorted_stacks() {
  std::vector<LayerStack> v;
  v.push_back(stack_of({slab(1.5, 0.1, Spectrum(0.5, 2.0, 10.0))}));
  v.push_back(stack_of({slab(1.3, 0.2, Spectrum(1.0), Spectrum(3.0)), slab(1.6, 0.05, Spectrum(0.0, 4.0, 40.0)),
                        slab(1.1, 1.0, Spectrum(0.2))}, 1.0, 1.33));
  v.push_back(stack_of({slab(1.0, 0.3, Spectrum(0.0))}));                  // index-matched, clear
  v.push_back(stack_of({slab(1.4, 0.0, Spectrum(5.0))}, 1.2, 1.7));        // zero thickness
  v.push_back(stack_of({slab(1.2, 0.1, Spectrum(1.0)), slab(1.5, kInfiniteThickness, Spectrum(0.1, 1.0, 7.0))}));
  v.push_back(stack_of({slab(1.5, 0.1, Spectrum(0.1)), slab(1.0, 0.1, Spectrum(0.1)),
                        slab(1.5, 0.1, Spectrum(0.1))}, 1.5, 1.5));        // TIR into the middle
  LayerStack lam = stack_of({slab(1.4, 0.2, Spectrum(0.7, 0.0, 3.0))});
  lam.below.kind = Below::Kind::Lambert;
  lam.below.albedo = Spectrum(0.5);
  v.push_back(lam);
  return v;
}

TEST(ZerothOrder, EnergyClosesForAssortedStacksAndAngles) {
  for (const LayerStack& s : assorted_stacks()) {
    for (double mu : {1.0, 0.9, 0.5, 0.2, 0.05, 1e-4, 1e-9, 0.0}) {
      const ZerothOrder z = zeroth_order(s, mu);
      for (int c = 0; c < kChannels; ++c) {
        // Every term is a sum of non-negative products, so rounding gives a few ulps only.
        EXPECT_NEAR(z.R_specular[c] + z.T_ballistic[c] + z.collided[c], 1.0, 1e-14) << "mu " << mu;
        EXPECT_GE(z.R_specular[c], 0.0);
        EXPECT_GE(z.T_ballistic[c], 0.0);
        EXPECT_GE(z.collided[c], 0.0);
      }
    }
  }
}

TEST(ZerothOrder, SemiInfiniteNormalIncidenceIsTheTopFresnelTerm) {
  // Nothing returns from an infinitely deep absorbing layer: R = ((n-1)/(n+1))^2 exactly.
  for (double n : {1.0, 1.33, 1.5, 2.4}) {
    const LayerStack s = stack_of({slab(n, kInfiniteThickness, Spectrum(0.1, 1.0, 100.0))});
    const ZerothOrder z = zeroth_order(s, 1.0);
    const double r = (n - 1) * (n - 1) / ((n + 1) * (n + 1));
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_NEAR(z.R_specular[c], r, 1e-16);
      EXPECT_EQ(z.T_ballistic[c], 0.0);
      EXPECT_NEAR(z.collided[c], 1.0 - r, 1e-15);
    }
  }
}

TEST(ZerothOrder, SlabAtNormalIncidenceIsStokesSeries) {
  // A plate in air at normal incidence: r = ((n-1)/(n+1))^2 at both faces, t = exp(-tau).
  // Summing the bounces: R = r + (1-r)^2 r t^2 / (1 - r^2 t^2), T = (1-r)^2 t / (1 - r^2 t^2)
  // (Stokes 1862). With t = 1 this is R = 2r/(1+r).
  const double n = 1.5, d = 0.4;
  const Spectrum sa(0.0, 1.0, 5.0);
  const ZerothOrder z = zeroth_order(stack_of({slab(n, d, sa)}), 1.0);
  const double r = (n - 1) * (n - 1) / ((n + 1) * (n + 1));
  for (int c = 0; c < kChannels; ++c) {
    const double t = std::exp(-sa[c] * d);
    const double R = r + (1 - r) * (1 - r) * r * t * t / (1 - r * r * t * t);
    const double T = (1 - r) * (1 - r) * t / (1 - r * r * t * t);
    EXPECT_NEAR(z.R_specular[c], R, 1e-15);
    EXPECT_NEAR(z.T_ballistic[c], T, 1e-15);
  }
  EXPECT_NEAR(z.R_specular[0], 2 * r / (1 + r), 1e-15);
}

TEST(ZerothOrder, IndexMatchedClearLayerIsInvisible) {
  for (double mu : {1.0, 0.3, 1e-6}) {
    const ZerothOrder z = zeroth_order(stack_of({slab(1.0, 2.0, Spectrum(0.0))}), mu);
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_EQ(z.T_ballistic[c], 1.0);
      EXPECT_EQ(z.R_specular[c], 0.0);
      EXPECT_EQ(z.collided[c], 0.0);
    }
    EXPECT_EQ(z.cos_below, mu);
  }
}

TEST(ZerothOrder, IndexMatchedAbsorberIsBeerLambert) {
  const double mu = 0.37, d = 0.8;
  const ZerothOrder z = zeroth_order(stack_of({slab(1.3, d, Spectrum(0.5, 2.0, 0.0))}, 1.3, 1.3), mu);
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_NEAR(z.T_ballistic[c], std::exp(-Spectrum(0.5, 2.0, 0.0)[c] * d / mu), 1e-15);
    EXPECT_EQ(z.R_specular[c], 0.0);
  }
}

TEST(ZerothOrder, TinyOpticalDepthKeepsRelativePrecision) {
  // collided is computed from expm1, not as 1 - R - T: an optical depth 1e-12 seen at mu = 0.5
  // collides with probability 1 - exp(-x) = x - x^2/2 + ..., x = 2e-12 (next term ~1e-36).
  const double mu = 0.5, x = 1e-12 / mu;
  const ZerothOrder z = zeroth_order(stack_of({slab(1.0, 1e-12, Spectrum(1.0))}), mu);
  EXPECT_NEAR(z.collided[0], x - 0.5 * x * x, 1e-15 * x);
}

TEST(ZerothOrder, SplittingALayerChangesNothing) {
  // Adding is associative: two index-matched halves must equal the whole.
  const Spectrum sa(0.3, 1.0, 3.0);
  const LayerStack one = stack_of({slab(1.4, 0.5, sa)}, 1.0, 1.2);
  const LayerStack two = stack_of({slab(1.4, 0.2, sa), slab(1.4, 0.3, sa)}, 1.0, 1.2);
  for (double mu : {1.0, 0.6, 0.1}) {
    const ZerothOrder a = zeroth_order(one, mu), b = zeroth_order(two, mu);
    for (int c = 0; c < kChannels; ++c) {
      EXPECT_NEAR(a.R_specular[c], b.R_specular[c], 1e-15);
      EXPECT_NEAR(a.T_ballistic[c], b.T_ballistic[c], 1e-15);
      EXPECT_NEAR(a.collided[c], b.collided[c], 1e-15);
      EXPECT_NEAR(a.collided_in_layer[0][c], b.collided_in_layer[0][c] + b.collided_in_layer[1][c], 1e-15);
    }
  }
}

// An independent estimator: follow the beam powers bounce by bounce (a Jacobi iteration on the
// fluxes at every interface) until nothing is left, instead of the closed-form adding.
struct BounceSum { double R = 0, T = 0, collided = 0; };
BounceSum bounce_by_bounce(const LayerStack& s, int c, double mu0) {
  const int n = static_cast<int>(s.layers.size());
  std::vector<double> mu(n), t(n), nn(n + 2);
  nn[0] = s.above_ior;
  for (int k = 0; k < n; ++k) nn[k + 1] = s.layers[k].ior;
  nn[n + 1] = s.below.ior;
  const double sin0 = std::sqrt(1 - mu0 * mu0);
  std::vector<double> mus(n + 2);
  for (int j = 0; j < n + 2; ++j) {
    const double sj = nn[0] * sin0 / nn[j];
    mus[j] = sj >= 1 ? -1 : std::sqrt(1 - sj * sj);
  }
  for (int k = 0; k < n; ++k) {
    mu[k] = mus[k + 1];
    const double tau = s.layers[k].optical_depth(c);
    t[k] = mu[k] < 0 ? 0 : std::exp(-tau / mu[k]);
  }
  auto R_iface = [&](int i) {  // interface i between media i and i+1 of nn
    if (mus[i] < 0 || mus[i + 1] < 0) return 1.0;
    return fresnel_dielectric(mus[i], nn[i], nn[i + 1]);
  };
  // down[k]: power going down at the top of layer k (just below interface k); up[k]: power
  // going up at the bottom of layer k (just above interface k+1).
  std::vector<double> down(n, 0.0), up(n, 0.0);
  BounceSum out;
  double incoming = 1.0;
  for (int iter = 0; iter < 200000; ++iter) {
    std::vector<double> nd(n, 0.0), nu(n, 0.0);
    // interface 0: incoming from above, up[.] arriving from layer 0 below.
    const double r0 = R_iface(0);
    out.R += incoming * r0;
    nd[0] += incoming * (1 - r0);
    double total = incoming;
    incoming = 0;
    for (int k = 0; k < n; ++k) {
      // beams crossing layer k
      const double arrive_bottom = down[k] * t[k], arrive_top = up[k] * t[k];
      out.collided += (down[k] + up[k]) * (1 - t[k]);
      total += down[k] + up[k];
      // at the top of layer k (interface k): arrive_top reflects down or passes up.
      const double rt = R_iface(k);
      nd[k] += arrive_top * rt;
      if (k == 0) out.R += arrive_top * (1 - rt); else nu[k - 1] += arrive_top * (1 - rt);
      // at the bottom (interface k+1)
      const double rb = R_iface(k + 1);
      nu[k] += arrive_bottom * rb;
      if (k == n - 1) out.T += arrive_bottom * (1 - rb); else nd[k + 1] += arrive_bottom * (1 - rb);
    }
    down = nd;
    up = nu;
    if (total < 1e-18) break;
  }
  return out;
}

TEST(ZerothOrder, MatchesBounceByBounceSum) {
  const LayerStack s = stack_of({slab(1.3, 0.2, Spectrum(1.0)), slab(1.6, 0.05, Spectrum(0.0, 4.0, 40.0)),
                                 slab(1.1, 0.1, Spectrum(0.2))}, 1.0, 1.33);
  const LayerStack tir = stack_of({slab(1.5, 0.1, Spectrum(0.1)), slab(1.2, 0.1, Spectrum(0.1)),
                                   slab(1.5, 0.1, Spectrum(0.1))}, 1.5, 1.5);
  for (const LayerStack* st : {&s, &tir}) {
    for (double mu : {1.0, 0.7, 0.3, 0.05}) {
      const ZerothOrder z = zeroth_order(*st, mu);
      for (int c = 0; c < kChannels; ++c) {
        const BounceSum b = bounce_by_bounce(*st, c, mu);
        // The iteration stops when 1e-18 is left; sums of O(100) terms round to ~1e-15.
        EXPECT_NEAR(z.R_specular[c], b.R, 1e-14) << mu;
        EXPECT_NEAR(z.T_ballistic[c], b.T, 1e-14) << mu;
        EXPECT_NEAR(z.collided[c], b.collided, 1e-14) << mu;
      }
    }
  }
}

TEST(ZerothOrder, TotalInternalReflectionIntoLowerIndex) {
  // From glass (1.5) onto a layer of 1.0 beyond the critical angle nothing enters.
  const LayerStack s = stack_of({slab(1.0, 0.1, Spectrum(1.0))}, 1.5, 1.5);
  const double mu = 0.5;  // sin = 0.866 > 1/1.5
  const ZerothOrder z = zeroth_order(s, mu);
  EXPECT_EQ(z.R_specular[0], 1.0);
  EXPECT_EQ(z.T_ballistic[0], 0.0);
  EXPECT_EQ(z.collided[0], 0.0);
  EXPECT_LT(z.cos_layer[0], 0.0);
}

TEST(ZerothOrder, GrazingIncidenceReflectsEverythingAtAMismatch) {
  const ZerothOrder z = zeroth_order(stack_of({slab(1.5, 0.1, Spectrum(1.0))}), 0.0);
  EXPECT_EQ(z.R_specular[0], 1.0);
  EXPECT_EQ(z.collided[0], 0.0);
}

TEST(ZerothOrder, LambertSubstrateReceivesTheRest) {
  LayerStack s = stack_of({slab(1.4, 0.2, Spectrum(0.5))});
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.8);
  const double mu = 0.8;
  const ZerothOrder z = zeroth_order(s, mu);
  // No interface at the substrate: the beam refracted in, attenuated once, is all absorbed or
  // scattered by the substrate; nothing comes back unscattered except the top Fresnel term.
  const double r = fresnel_dielectric(mu, 1.0, 1.4);
  const double mu1 = refracted_cos(mu, 1.0, 1.4);
  EXPECT_NEAR(z.R_specular[0], r, 1e-16);
  EXPECT_NEAR(z.reaches_substrate[0], (1 - r) * std::exp(-0.5 * 0.2 / mu1), 1e-15);
  EXPECT_EQ(z.T_ballistic[0], 0.0);
}

}  // namespace
}  // namespace lamina
