// The analytic single-scattering BRDF/BTDF: reciprocity, the equal-cosine limit, an independent
// brute-force depth quadrature with explicitly summed bounces, layer splitting, the Lambert
// substrate, and the extremes (tau 0 and infinite, grazing, TIR, g near +-1).
#include "materials/analytic/first_order.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "materials/interfaces/fresnel.h"
#include "materials/phase/henyey_greenstein.h"
#include "materials/base/sampling.h"
#include "materials/analytic/zeroth_order.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

Layer layer(double ior, double d, Spectrum sa, Spectrum ss, Spectrum g) {
  return make_layer("l", ior, d, sa, ss, g);
}

using test::stack_of;

glm::dvec3 dir(double theta_deg, double phi_deg, double sign = 1.0) {
  const double t = theta_deg * kPi / 180, p = phi_deg * kPi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), sign * std::cos(t)};
}
glm::dvec3 flip_z(const glm::dvec3& v) { return {v.x, v.y, -v.z}; }

// A three-layer stack with different indices everywhere, a composite layer and coloured g.
LayerStack rich_stack() {
  Layer mid = layer(1.6, 0.08, Spectrum(0.2, 1.0, 3.0), Spectrum(20.0), Spectrum(0.0));
  mid.lobes.push_back({Spectrum(5.0, 10.0, 2.0), Spectrum(0.85, -0.4, 0.6)});
  return stack_of({layer(1.3, 0.05, Spectrum(0.5), Spectrum(15.0, 8.0, 30.0), Spectrum(0.3, 0.5, -0.2)), mid,
                   layer(1.45, 0.2, Spectrum(0.1), Spectrum(4.0), Spectrum(0.7))},
                  1.0, 1.2);
}

LayerStack lambert_stack() {
  LayerStack s = stack_of({layer(1.4, 0.1, Spectrum(1.0), Spectrum(10.0), Spectrum(0.5)),
                           layer(1.3, 0.05, Spectrum(2.0, 0.0, 5.0), Spectrum(3.0), Spectrum(-0.3))});
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.6, 0.3, 0.9);
  return s;
}

std::vector<glm::dvec3> some_directions(double sign) {
  std::vector<glm::dvec3> v;
  for (double th : {0.0, 15.0, 40.0, 63.0, 80.0, 89.0})
    for (double ph : {0.0, 75.0, 180.0, 300.0}) v.push_back(dir(th, ph, sign));
  return v;
}

TEST(FirstOrder, BrdfIsReciprocal) {
  for (const LayerStack& s : {rich_stack(), lambert_stack()}) {
    for (const glm::dvec3& wi : some_directions(1))
      for (const glm::dvec3& wo : some_directions(1)) {
        const Spectrum a = first_order_brdf(s, wi, wo), b = first_order_brdf(s, wo, wi);
        for (int c = 0; c < kChannels; ++c) {
          // Same terms in a different order: rounding only.
          EXPECT_NEAR(a[c], b[c], 1e-12 * std::max(a[c], 1e-300)) << wi.z << " " << wo.z;
          EXPECT_GE(a[c], 0.0);
        }
      }
  }
}

TEST(FirstOrder, BtdfGeneralisedReciprocity) {
  // f_t(wi -> wo) / n_o^2 = f_t(wo -> wi) / n_i^2, light from below evaluated on flipped().
  const LayerStack s = rich_stack();
  const LayerStack f = flipped(s);
  for (const glm::dvec3& wi : some_directions(1))
    for (const glm::dvec3& wo : some_directions(-1)) {
      const Spectrum forward = first_order_btdf(s, wi, wo) / (s.below.ior * s.below.ior);
      const Spectrum backward = first_order_btdf(f, flip_z(wo), flip_z(wi)) / (s.above_ior * s.above_ior);
      for (int c = 0; c < kChannels; ++c)
        EXPECT_NEAR(forward[c], backward[c], 1e-12 * std::max(forward[c], 1e-300)) << wi.z << " " << wo.z;
    }
}

TEST(FirstOrder, BtdfStraightThroughIsTheExactEqualCosineLimit) {
  // Index-matched single layer, wo = -wi: a = 1, b = 0, nothing bounces, so
  //   f_t = W p(1) lim_{mu_o -> mu_i} (e^{-tau/mu_i} - e^{-tau/mu_o})/(mu_i - mu_o)
  //       = W p(1) tau e^{-tau/mu}/mu^2.
  const double sa = 0.7, ss = 3.0, d = 0.4, g = 0.6;
  const LayerStack s = stack_of({layer(1.0, d, Spectrum(sa), Spectrum(ss), Spectrum(g))});
  for (double th : {0.0, 30.0, 70.0, 89.9}) {
    const glm::dvec3 wi = dir(th, 20.0);
    const double mu = wi.z, tau = (sa + ss) * d;
    const double expect = ss / (sa + ss) * henyey_greenstein(1.0, g) * tau * std::exp(-tau / mu) / (mu * mu);
    EXPECT_NEAR(first_order_btdf(s, wi, -wi)[0], expect, 1e-13 * expect) << th;
  }
}

TEST(FirstOrder, EqualCosineLimitIsContinuous) {
  // mu_o = mu_i (1 +- 1e-8) against mu_o = mu_i exactly: f is smooth there, so the change must be
  // of order |df/dmu| 1e-8 mu, i.e. relative ~1e-8 times a modest factor (<= 1e-6 here), where a
  // naive (e^-x - e^-y)/(mu_i - mu_o) would lose about half the digits.
  for (const LayerStack& s : {rich_stack(), stack_of({layer(1.0, 0.3, Spectrum(1.0), Spectrum(5.0), Spectrum(0.8))})}) {
    for (double th : {0.0, 25.0, 60.0, 85.0}) {
      const glm::dvec3 wi = dir(th, 0.0);
      const double st = std::sqrt(1 - wi.z * wi.z);
      const Spectrum exact = first_order_btdf(s, wi, glm::dvec3(-wi.x, -wi.y, -wi.z));
      for (double eps : {1e-8, -1e-8}) {
        const double mu = std::min(1.0, wi.z * (1 + eps));
        const double sn = std::sqrt(1 - mu * mu);
        // same azimuth plane; the horizontal part follows from mu
        const glm::dvec3 wo{th == 0.0 ? 0.0 : -sn * wi.x / st, 0.0, -mu};
        const Spectrum near = first_order_btdf(s, wi, glm::normalize(wo));
        for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(near[c], exact[c], 1e-6 * exact[c]) << th << " " << eps;
      }
      // and the BRDF at wo = mirror direction (the dn->dn/up->up K terms see mu_o = mu_i too)
      const Spectrum r = first_order_brdf(s, wi, {-wi.x, -wi.y, wi.z});
      EXPECT_TRUE(r.is_finite());
    }
  }
}

TEST(FirstOrder, SemiInfiniteEqualsVeryThick) {
  // e^{-1e6 * 30} underflows to 0, so thickness 1e6 must give the same numbers as "inf" to
  // rounding.
  for (double below : {1.0, 1.5}) {
    const LayerStack inf = stack_of({layer(1.3, 0.1, Spectrum(0.5), Spectrum(8.0), Spectrum(0.4)),
                                     layer(1.5, kInfiniteThickness, Spectrum(0.3), Spectrum(30.0), Spectrum(0.7))},
                                    1.0, below);
    LayerStack thick = inf;
    thick.layers[1].thickness = 1e6;
    for (const glm::dvec3& wi : some_directions(1))
      for (const glm::dvec3& wo : some_directions(1)) {
        const Spectrum a = first_order_brdf(inf, wi, wo), b = first_order_brdf(thick, wi, wo);
        for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(a[c], b[c], 1e-14 * a[c]);
      }
    EXPECT_TRUE(first_order_btdf(inf, dir(10, 0), dir(10, 0, -1)).is_black());
  }
}

TEST(FirstOrder, SemiInfiniteIndexMatchedIsLommelSeeliger) {
  const double sa = 0.4, ss = 2.0, g = -0.3;
  const LayerStack s = stack_of({layer(1.0, kInfiniteThickness, Spectrum(sa), Spectrum(ss), Spectrum(g))});
  for (const glm::dvec3& wi : some_directions(1))
    for (const glm::dvec3& wo : some_directions(1)) {
      const glm::dvec3 in_prop = -wi;
      const double cos_scatter = in_prop.x * wo.x + in_prop.y * wo.y + in_prop.z * wo.z;
      const double expect = ss / (sa + ss) * henyey_greenstein(cos_scatter, g) / (wi.z + wo.z);
      EXPECT_NEAR(first_order_brdf(s, wi, wo)[1], expect, 1e-13 * expect);
    }
}

TEST(FirstOrder, ZeroOpticalDepthGivesZero) {
  const LayerStack clear = stack_of({layer(1.5, 1.0, Spectrum(0.0), Spectrum(0.0), Spectrum(0.5))});
  const LayerStack thin = stack_of({layer(1.5, 0.0, Spectrum(1.0), Spectrum(10.0), Spectrum(0.5))});
  for (const LayerStack* s : {&clear, &thin})
    for (const glm::dvec3& wi : some_directions(1)) {
      EXPECT_TRUE(first_order_brdf(*s, wi, dir(30, 100)).is_black());
      EXPECT_TRUE(first_order_btdf(*s, wi, dir(30, 100, -1)).is_black());
    }
}

// ---- Independent brute force for one layer between media n0 (above) and n2 (below) ----
// Bounces are summed term by term (not by the closed forms), directions inside come from the
// vector refraction refract_through_plane (not from the scalar invariant), and the depth
// integral is done by composite Gauss-Legendre quadrature (not by A and K).
struct BruteForce { double value = 0; double exponent = 0; };
BruteForce brute_force_single_layer(double n0, double n1, double n2, double d, double sa, double ss, double g,
                                    glm::dvec3 wi, glm::dvec3 wo, int panels) {
  const double st = sa + ss;
  const bool transmit = wo.z < 0;
  const double n_out = transmit ? n2 : n0;
  // incident propagation direction inside (going down)
  glm::dvec3 pin = -wi;
  if (!refract_through_plane(&pin, n0, n1)) return {};
  // outgoing propagation inside: reverse the exit refraction (wo is the propagation direction
  // outside; inside it is the direction that refracts to wo, found by refracting -wo inwards).
  glm::dvec3 pout = -wo;
  if (!refract_through_plane(&pout, n_out, n1)) return {};
  pout = -pout;  // propagation towards the exit interface
  const double mui = -pin.z, muo = std::abs(pout.z);
  const double R01i = fresnel_dielectric(wi.z, n0, n1), R12i = fresnel_dielectric(mui, n1, n2);
  const double R10o = fresnel_dielectric(muo, n1, n0), R12o = fresnel_dielectric(muo, n1, n2);
  const double ti = std::exp(-st * d / mui), to = std::exp(-st * d / muo);
  auto series = [](double ratio) {  // sum_m ratio^m, term by term
    double sum = 0, term = 1;
    for (int m = 0; m < 100000 && term > 1e-22; ++m) { sum += term; term *= ratio; }
    return sum;
  };
  const double loop_i = series(R01i * R12i * ti * ti);  // R10 = R01 at Snell-related angles
  const double loop_o = series(R10o * R12o * to * to);
  const double exit_T = transmit ? (1 - R12o) : (1 - R10o);
  const double far_R = transmit ? R10o : R12o;
  const double radiance = (n_out / n1) * (n_out / n1);
  // the four propagation directions
  const glm::dvec3 in_dn = pin, in_up = flip_z(pin);
  const glm::dvec3 out_exit = pout, out_far = flip_z(pout);
  auto p = [&](const glm::dvec3& a, const glm::dvec3& b) { return henyey_greenstein(glm::dot(a, b), g); };
  std::vector<double> x(16), w(16);
  gauss_legendre(16, 0.0, 1.0, x.data(), w.data());
  double integral = 0;
  for (int k = 0; k < panels; ++k) {
    for (int j = 0; j < 16; ++j) {
      const double z = d * (k + x[j]) / panels, wz = d * w[j] / panels;
      const double F_dn = (1 - R01i) * loop_i * std::exp(-st * z / mui);
      const double F_up = (1 - R01i) * loop_i * ti * R12i * std::exp(-st * (d - z) / mui);
      // distance to the exit boundary and to the far boundary
      const double to_exit = transmit ? d - z : z, to_far = transmit ? z : d - z;
      const double E_exit = std::exp(-st * to_exit / muo) * loop_o * exit_T * radiance;
      const double E_far = std::exp(-st * to_far / muo) * far_R * to * loop_o * exit_T * radiance;
      const double src = ss / (mui * muo);
      integral += wz * src *
                  (F_dn * (p(in_dn, out_exit) * E_exit + p(in_dn, out_far) * E_far) +
                   F_up * (p(in_up, out_exit) * E_exit + p(in_up, out_far) * E_far));
    }
  }
  // the largest exponent: a relative error e in a cosine changes e^{-x} by x e (conditioning)
  return {integral, st * d * (1 / mui + 1 / muo)};
}

TEST(FirstOrder, MatchesBruteForceDepthQuadrature) {
  struct Case { double n0, n1, n2; };
  const double d = 0.3, sa = 1.5, ss = 6.0, g = 0.55;
  for (Case cs : {Case{1.0, 1.0, 1.0}, Case{1.0, 1.5, 1.2}, Case{1.3, 1.1, 1.7}}) {
    const LayerStack s = stack_of({layer(cs.n1, d, Spectrum(sa), Spectrum(ss), Spectrum(g))}, cs.n0, cs.n2);
    for (double sign : {1.0, -1.0})
      for (const glm::dvec3& wi : some_directions(1))
        for (const glm::dvec3& wo : some_directions(sign)) {
          const double f = sign > 0 ? first_order_brdf(s, wi, wo)[0] : first_order_btdf(s, wi, wo)[0];
          const BruteForce b1 = brute_force_single_layer(cs.n0, cs.n1, cs.n2, d, sa, ss, g, wi, wo, 8);
          const BruteForce b2 = brute_force_single_layer(cs.n0, cs.n1, cs.n2, d, sa, ss, g, wi, wo, 16);
          const double q1 = b1.value, q2 = b2.value;
          // The quadrature error is bounded by the difference between 8 and 16 panels (the
          // smooth integrand makes the finer one far better); add rounding of ~100 terms and
          // the conditioning of e^{-x}: cosines carry a few ulps from the two different
          // refraction codes, which moves e^{-x} by x * (few eps). The brute force evaluates the
          // exit Fresnel term from inside, where a grazing outside cosine c is found from
          // cos^2 = (1 - eta^2) + eta^2 cos_in^2 with cancellation: relative error ~eps/c^2.
          const double graze = 1 / (wi.z * wi.z) + 1 / (wo.z * wo.z);
          const double tol = 10 * std::abs(q2 - q1) + (1e-13 + 1e-15 * b2.exponent + 1e-15 * graze) * std::abs(q2);
          EXPECT_NEAR(f, q2, tol) << cs.n0 << " " << cs.n1 << " " << cs.n2 << " wi.z " << wi.z << " wo.z " << wo.z;
        }
  }
}

// ---- Independent brute force for a multi-layer stack ----
// Beams are followed interface by interface (a Jacobi iteration on beam powers, no closed-form
// adding), for the incident light and, separately, for the escape of a beam started inside a
// layer; the depth integral is done by quadrature. Finite layers, one HG lobe each.
struct BounceSystem {
  const LayerStack& s;
  int n;
  std::vector<double> nn, mu, t;  // media 0..n+1 (0 above, k+1 = layer k, n+1 below)
  bool lambert;
  BounceSystem(const LayerStack& st, double invariant) : s(st), n(int(st.layers.size())) {
    lambert = s.below.kind == Below::Kind::Lambert;
    nn.push_back(s.above_ior);
    for (const Layer& l : s.layers) nn.push_back(l.ior);
    nn.push_back(lambert ? s.layers.back().ior : s.below.ior);
    for (double ni : nn) {
      const double sn = invariant / ni;
      mu.push_back(sn >= 1 ? -1.0 : std::sqrt((1 - sn) * (1 + sn)));
    }
    for (int k = 0; k < n; ++k)
      t.push_back(mu[k + 1] < 0 ? 0.0 : std::exp(-s.layers[k].optical_depth(0) / mu[k + 1]));
  }
  double R(int j) const {  // interface between media j and j+1
    if (mu[j] < 0 || mu[j + 1] < 0) return 1.0;
    if (lambert && j == n) return 0.0;
    return fresnel_dielectric(mu[j], nn[j], nn[j + 1]);
  }
  struct Result { std::vector<double> down, up; double out_top = 0, out_bottom = 0; };
  // Inject: 'from_above' a unit beam onto interface 0; or a unit beam in layer k arriving at
  // its top (heading up), or at its bottom (heading down), or starting up from the bottom.
  enum class Kind { FromAbove, ArriveTop, ArriveBottom, StartUpAtBottom };
  Result run(Kind kind, int k) const {
    Result r;
    r.down.assign(n, 0.0);
    r.up.assign(n, 0.0);
    std::vector<double> at_top(n, 0.0), at_bot(n, 0.0), start_dn(n, 0.0), start_up(n, 0.0);
    if (kind == Kind::FromAbove) { r.out_top += R(0); start_dn[0] = 1 - R(0); }
    if (kind == Kind::ArriveTop) at_top[k] = 1;
    if (kind == Kind::ArriveBottom) at_bot[k] = 1;
    if (kind == Kind::StartUpAtBottom) start_up[k] = 1;
    for (int iter = 0; iter < 1000000; ++iter) {
      double left = 0;
      for (int j = 0; j < n; ++j) {  // interfaces act on arriving beams
        const double rt = R(j), rb = R(j + 1);
        start_dn[j] += at_top[j] * rt;
        if (j == 0) r.out_top += at_top[j] * (1 - rt); else start_up[j - 1] += at_top[j] * (1 - rt);
        start_up[j] += at_bot[j] * rb;
        if (j == n - 1) r.out_bottom += at_bot[j] * (1 - rb); else start_dn[j + 1] += at_bot[j] * (1 - rb);
      }
      for (int j = 0; j < n; ++j) {  // beams cross the layers
        r.down[j] += start_dn[j];
        r.up[j] += start_up[j];
        at_bot[j] = start_dn[j] * t[j];
        at_top[j] = start_up[j] * t[j];
        left += at_bot[j] + at_top[j];
        start_dn[j] = start_up[j] = 0;
      }
      if (left < 1e-20) break;
    }
    return r;
  }
};

double brute_force_stack(const LayerStack& s, glm::dvec3 wi, glm::dvec3 wo, int panels) {
  const bool transmit = wo.z < 0;
  const double n_out = transmit ? s.below.ior : s.above_ior;
  const double si = s.above_ior * std::sqrt(1 - wi.z * wi.z), so = n_out * std::sqrt(1 - wo.z * wo.z);
  const BounceSystem in(s, si), out(s, so);
  const auto incident = in.run(BounceSystem::Kind::FromAbove, 0);
  std::vector<double> x(16), w(16);
  gauss_legendre(16, 0.0, 1.0, x.data(), w.data());
  double f = 0;
  for (int k = 0; k < in.n; ++k) {
    const Layer& L = s.layers[k];
    const double mui = in.mu[k + 1], muo = out.mu[k + 1];
    if (mui <= 0 || muo <= 0) continue;
    const double st = L.sigma_t()[0], ss = L.sigma_s()[0], g = L.lobes[0].g[0], d = L.thickness;
    // propagation directions inside, from the invariants (horizontal parts along wi_xy, wo_xy)
    const double hi = si / L.ior, ho = so / L.ior;
    const double li = std::hypot(wi.x, wi.y), lo = std::hypot(wo.x, wo.y);
    const glm::dvec3 ui = li > 0 ? glm::dvec3(-wi.x / li, -wi.y / li, 0) : glm::dvec3(0), uo = lo > 0 ? glm::dvec3(wo.x / lo, wo.y / lo, 0) : glm::dvec3(0);
    const glm::dvec3 in_dn = hi * ui + glm::dvec3(0, 0, -mui), in_up = hi * ui + glm::dvec3(0, 0, mui);
    const glm::dvec3 out_up = ho * uo + glm::dvec3(0, 0, muo), out_dn = ho * uo + glm::dvec3(0, 0, -muo);
    auto p = [&](const glm::dvec3& a, const glm::dvec3& b) { return henyey_greenstein(glm::dot(a, b), g); };
    // escape (towards the exit side) of a beam arriving at the top / bottom of layer k
    const auto esc_up = out.run(BounceSystem::Kind::ArriveTop, k);
    const auto esc_dn = out.run(BounceSystem::Kind::ArriveBottom, k);
    const double E_up = transmit ? esc_up.out_bottom : esc_up.out_top;
    const double E_dn = transmit ? esc_dn.out_bottom : esc_dn.out_top;
    const double radiance = (n_out / L.ior) * (n_out / L.ior);
    for (int pnl = 0; pnl < panels; ++pnl)
      for (int j = 0; j < 16; ++j) {
        const double z = d * (pnl + x[j]) / panels, wz = d * w[j] / panels;
        const double Fdn = incident.down[k] * std::exp(-st * z / mui);
        const double Fup = incident.up[k] * std::exp(-st * (d - z) / mui);
        const double go_up = std::exp(-st * z / muo) * E_up, go_dn = std::exp(-st * (d - z) / muo) * E_dn;
        f += wz * ss / (mui * muo) * radiance *
             ((Fdn * p(in_dn, out_up) + Fup * p(in_up, out_up)) * go_up +
              (Fdn * p(in_dn, out_dn) + Fup * p(in_up, out_dn)) * go_dn);
      }
  }
  if (in.lambert && !transmit) {
    // unscattered power reaching the substrate, times rho/pi, times the escape of a beam
    // starting up from the substrate (beams sent back down to it are a second bounce: dropped)
    const double reach = incident.out_bottom;
    const auto esc = out.run(BounceSystem::Kind::StartUpAtBottom, in.n - 1);
    const double eta = s.above_ior / s.layers.back().ior;
    f += s.below.albedo[0] / kPi * reach * esc.out_top * eta * eta;
  }
  return f;
}

TEST(FirstOrder, MatchesMultiLayerBruteForce) {
  const LayerStack mismatched = stack_of({layer(1.3, 0.05, Spectrum(0.5), Spectrum(15.0), Spectrum(0.3)),
                                          layer(1.6, 0.08, Spectrum(1.0), Spectrum(20.0), Spectrum(-0.4)),
                                          layer(1.1, 0.2, Spectrum(0.1), Spectrum(4.0), Spectrum(0.7))},
                                         1.0, 1.2);
  const LayerStack glass_tir = stack_of({layer(1.5, 0.1, Spectrum(0.2), Spectrum(6.0), Spectrum(0.5)),
                                         layer(1.2, 0.1, Spectrum(0.4), Spectrum(3.0), Spectrum(0.0)),
                                         layer(1.5, 0.1, Spectrum(0.2), Spectrum(6.0), Spectrum(0.8))},
                                        1.5, 1.0);
  LayerStack lam = stack_of({layer(1.4, 0.1, Spectrum(1.0), Spectrum(10.0), Spectrum(0.5)),
                             layer(1.3, 0.05, Spectrum(2.0), Spectrum(3.0), Spectrum(-0.3))});
  lam.below.kind = Below::Kind::Lambert;
  lam.below.albedo = Spectrum(0.6);
  std::vector<glm::dvec3> dirs_up, dirs_dn;  // <= 80 deg: the brute force's cosines are plain sqrt
  for (double th : {0.0, 20.0, 45.0, 70.0, 80.0})
    for (double ph : {0.0, 130.0, 180.0}) {
      dirs_up.push_back(dir(th, ph, 1));
      dirs_dn.push_back(dir(th, ph, -1));
    }
  double worst = 0;
  for (const LayerStack* s : {&mismatched, &glass_tir, static_cast<const LayerStack*>(&lam)})
    for (const glm::dvec3& wi : dirs_up)
      for (const auto* set : {&dirs_up, &dirs_dn})
        for (const glm::dvec3& wo : *set) {
          if (wo.z < 0 && !s->transmits()) continue;
          const double f = first_order_bsdf(*s, wi, wo)[0];
          const double q1 = brute_force_stack(*s, wi, wo, 4), q2 = brute_force_stack(*s, wi, wo, 8);
          // quadrature error bounded by the 4- vs 8-panel difference; the iteration stops at
          // 1e-20 of the power; cosines from sqrt(1 - (s/n)^2) carry ~eps/mu^2 (mu >= 0.17 here)
          // amplified by optical depths/mu <= ~50 in the exponents.
          const double tol = 10 * std::abs(q2 - q1) + 1e-12 * std::abs(q2) + 1e-18;
          EXPECT_NEAR(f, q2, tol) << "wi.z " << wi.z << " wo " << wo.x << "," << wo.y << "," << wo.z;
          if (q2 > 0) worst = std::max(worst, std::abs(f - q2) / q2);
        }
  RecordProperty("worst_relative_difference", std::to_string(worst));
  std::printf("multi-layer brute force: worst relative difference %.3g\n", worst);
}

TEST(FirstOrder, SplittingALayerChangesNothing) {
  // Two index-matched halves of a layer: every single-scattering path of the whole is one of
  // the halves' paths, with the other half's attenuation in the unscattered legs.
  const Layer whole = layer(1.4, 0.3, Spectrum(0.5, 1.0, 2.0), Spectrum(5.0, 9.0, 1.0), Spectrum(0.6, 0.0, -0.5));
  Layer top = whole, bottom = whole;
  top.thickness = 0.1;
  bottom.thickness = 0.2;
  const LayerStack one = stack_of({layer(1.2, 0.05, Spectrum(0.3), Spectrum(3.0), Spectrum(0.2)), whole}, 1.0, 1.1);
  const LayerStack two = stack_of({layer(1.2, 0.05, Spectrum(0.3), Spectrum(3.0), Spectrum(0.2)), top, bottom}, 1.0, 1.1);
  for (double sign : {1.0, -1.0})
    for (const glm::dvec3& wi : some_directions(1))
      for (const glm::dvec3& wo : some_directions(sign)) {
        const Spectrum a = first_order_bsdf(one, wi, wo), b = first_order_bsdf(two, wi, wo);
        for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(a[c], b[c], 1e-13 * a[c]) << wi.z << " " << wo.z;
      }
}

TEST(FirstOrder, LambertSubstrateUnderClearMatchedLayerIsLambert) {
  LayerStack s = stack_of({layer(1.0, 0.5, Spectrum(0.0), Spectrum(0.0), Spectrum(0.0))});
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.2, 0.5, 1.0);
  for (const glm::dvec3& wi : some_directions(1))
    for (const glm::dvec3& wo : some_directions(1)) {
      const Spectrum f = first_order_brdf(s, wi, wo);
      for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(f[c], s.below.albedo[c] / kPi, 1e-16);
    }
  // and its albedo, by the quadrature, is the substrate's
  const FirstOrderAlbedo a = first_order_albedo(s, 0.6);
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(a.R_diffuse[c], s.below.albedo[c], 1e-13);
}

TEST(FirstOrder, LambertSubstrateUnderMismatchedAbsorber) {
  // f = rho/pi T(i) T(o) (n0/n1)^2 with T = (1 - Fresnel) e^{-tau/mu}, no bounces (the substrate
  // has no interface, so nothing unscattered comes back up to be reflected down again).
  const double n = 1.5, sa = 2.0, d = 0.1, rho = 0.7;
  LayerStack s = stack_of({layer(n, d, Spectrum(sa), Spectrum(0.0), Spectrum(0.0))});
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(rho);
  for (const glm::dvec3& wi : some_directions(1))
    for (const glm::dvec3& wo : some_directions(1)) {
      auto T = [&](double mu) {
        return (1 - fresnel_dielectric(mu, 1.0, n)) * std::exp(-sa * d / refracted_cos(mu, 1.0, n));
      };
      const double expect = rho / kPi * T(wi.z) * T(wo.z) / (n * n);
      EXPECT_NEAR(first_order_brdf(s, wi, wo)[0], expect, 1e-15 * std::max(expect, 1.0));
    }
}

TEST(FirstOrder, ThinLayerSingleScatteringIsAllOfTheScattering) {
  // For tau -> 0 in an index-matched layer almost every scattered photon escapes unscattered:
  // R1 + T1 = W collided (1 - O(tau ln(1/tau))). With tau = 1e-6 the relative gap is < ~2e-5;
  // the quadrature of the smooth integrand is accurate far beyond that.
  const double tau = 1e-6, W = 0.8;
  const LayerStack s = stack_of({layer(1.0, 1.0, Spectrum(tau * (1 - W)), Spectrum(tau * W), Spectrum(0.0))});
  for (double mu : {1.0, 0.6, 0.2}) {
    const FirstOrderAlbedo a = first_order_albedo(s, mu);
    const ZerothOrder z = zeroth_order(s, mu);
    const double expect = W * z.collided[0];
    EXPECT_NEAR(a.R_diffuse[0] + a.T_diffuse[0], expect, 10 * tau * std::log(1 / tau) * expect) << mu;
    // isotropic: half up, half down (to the same order)
    EXPECT_NEAR(a.R_diffuse[0], a.T_diffuse[0], 10 * tau * std::log(1 / tau) * expect) << mu;
  }
}

TEST(FirstOrder, SingleScatteringNeverExceedsTheScatteredPower) {
  // Energy: what leaves after one scattering is at most what scatters first,
  // sum_k W_k collided_k + rho reaches_substrate.
  for (const LayerStack& s : {rich_stack(), lambert_stack()}) {
    for (double mu : {1.0, 0.5, 0.1}) {
      const FirstOrderAlbedo a = first_order_albedo(s, mu, 64, 128);
      const ZerothOrder z = zeroth_order(s, mu);
      for (int c = 0; c < kChannels; ++c) {
        double scattered = s.below.kind == Below::Kind::Lambert ? s.below.albedo[c] * z.reaches_substrate[c] : 0.0;
        for (std::size_t k = 0; k < s.layers.size(); ++k) scattered += s.layers[k].albedo()[c] * z.collided_in_layer[k][c];
        EXPECT_LE(a.R_diffuse[c] + a.T_diffuse[c], scattered) << mu << " " << c;
        EXPECT_GT(a.R_diffuse[c], 0.0);
      }
    }
  }
}

TEST(FirstOrder, FiniteAtTheExtremes) {
  std::vector<LayerStack> stacks;
  for (double g : {-0.9999, -0.5, 0.0, 1e-9, 0.9999})
    for (double tau : {1e-300, 1e-8, 1.0, 1e3, 1e300})
      for (double W : {0.0, 1e-12, 0.5, 1.0})
        for (double n : {1.0, 1.5, 0.7})
          stacks.push_back(stack_of({layer(n, 1.0, Spectrum(tau * (1 - W)), Spectrum(tau * W), Spectrum(g))}, 1.0, 1.33));
  const std::vector<double> thetas = {0.0, 1e-7, 45.0, 89.0, 90.0 - 1e-7, 90.0};
  for (const LayerStack& s : stacks)
    for (double ti : thetas)
      for (double to : thetas)
        for (double ph : {0.0, 180.0}) {
          const Spectrum r = first_order_brdf(s, dir(ti, 0), dir(to, ph));
          const Spectrum t = first_order_btdf(s, dir(ti, 0), dir(to, ph, -1));
          ASSERT_TRUE(r.is_finite() && t.is_finite()) << ti << " " << to << " " << s.layers[0].lobes[0].g[0];
          EXPECT_GE(r.min(), 0.0);
          EXPECT_GE(t.min(), 0.0);
        }
}

TEST(FirstOrder, TotalInternalReflectionBlocksExit) {
  // Layer 1.5 between glass 1.5 above and air below: a transmitted direction in air maps inside
  // to sin = sin_air / 1.5, always possible; but light from glass at 60 deg cannot reach air
  // unscattered, and an outgoing direction into glass is always reachable. Check the converse:
  // above 1.0, layer 1.0, below 1.0 with a 1.8 film on top -> no TIR for entering light.
  // Here: from above n = 1.6 onto a layer of 1.0 beyond the critical angle, nothing enters.
  const LayerStack s = stack_of({layer(1.0, 0.2, Spectrum(0.1), Spectrum(5.0), Spectrum(0.0))}, 1.6, 1.6);
  const glm::dvec3 wi = dir(60, 0);  // 1.6 sin 60 = 1.39 > 1
  EXPECT_TRUE(first_order_brdf(s, wi, dir(10, 0)).is_black());
  EXPECT_TRUE(first_order_btdf(s, wi, dir(10, 0, -1)).is_black());
  // and from a steep direction, light scatters but cannot leave at 60 deg
  EXPECT_TRUE(first_order_brdf(s, dir(10, 0), wi).is_black());
  EXPECT_FALSE(first_order_brdf(s, dir(10, 0), dir(20, 0)).is_black());
}

TEST(FirstOrder, GaussLegendreIntegratesPolynomialsExactly) {
  for (int n : {1, 2, 5, 16, 48}) {
    std::vector<double> x(n), w(n);
    gauss_legendre(n, 0.0, 2.0, x.data(), w.data());
    for (int p = 0; p <= 2 * n - 1; ++p) {
      double sum = 0;
      for (int i = 0; i < n; ++i) sum += w[i] * std::pow(x[i], p);
      const double exact = std::pow(2.0, p + 1) / (p + 1);
      EXPECT_NEAR(sum, exact, 1e-13 * exact) << n << " " << p;
    }
  }
}

TEST(FirstOrder, BihemisphericalAlbedoOfLambertUnderMatchedClearLayer) {
  LayerStack s = stack_of({layer(1.0, 0.5, Spectrum(0.0), Spectrum(0.0), Spectrum(0.0))});
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.25);
  const FirstOrderAlbedo a = first_order_bihemispherical_albedo(s, 8, 16, 16);
  EXPECT_NEAR(a.R_diffuse[0], 0.25, 1e-13);
}

}  // namespace
}  // namespace lamina
