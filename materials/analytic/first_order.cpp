#include "materials/analytic/first_order.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "materials/base/sampling.h"
#include "materials/analytic/zeroth_order.h"

// Derivation of the single-scattering BRDF/BTDF of a stack
// ========================================================
// Notation for one channel. Irradiance E (power per unit horizontal area) arrives from above in
// direction wi. Scattering layer k: index n_k, thickness d, sigma_t, sigma_s, albedo
// W = sigma_s/sigma_t, optical depth tau = sigma_t d, normalised phase function p (the lobe
// mixture, sigma_s p = sum_j sigma_s,j p_HG(g_j)). Depth z in [0, d] from the top of layer k.
// mu_i, mu_o: cosines of the incident and outgoing beams inside layer k (Snell: the horizontal
// invariant n sin(theta) is kept, so they follow from wi.z and wo.z alone);
// x = tau/mu_i, y = tau/mu_o; t_i = e^-x, t_o = e^-y (one pass through layer k).
//
// 1. Unscattered light in layer k. From zeroth_order.h: U = everything above layer k, D =
//    everything below it (each with the series of bounces inside it summed). Power per unit
//    horizontal area of the downward beam at the top of layer k (bounces between U and D summed):
//       a E,   a = T_U(i) / (1 - R'_U(i) R_D(i) t_i^2);
//    that of the upward beam at its bottom: b E, b = a t_i R_D(i). So at depth z the downward
//    beam carries a E e^{-sigma_t z/mu_i}, the upward one b E e^{-sigma_t (d-z)/mu_i}.
//    (Power, not radiance: a refracted beam's power per unit horizontal area is just multiplied
//    by T; no n^2 and no cosine enter here.)
// 2. Scattering. A beam of power F per unit horizontal area has power F/mu_i per unit area
//    normal to it, so the radiance it scatters per unit length of path in direction w is
//    sigma_s (F/mu_i) p(cos), cos between the propagation directions. Integrating along the
//    outgoing path, which crosses the slab [z, z+dz] over a length dz/mu_o, with attenuation to
//    the layer boundary it heads for:
//       dL = sigma_s p F(z)/(mu_i mu_o) e^{-sigma_t l(z)/mu_o} dz.
//    The depth integrals (sigma_s/(mu_i mu_o) int_0^d ... dz) are two functions only:
//       same side  (beam and outgoing path attenuated from the same boundary):
//          A = W (1 - e^{-(x+y)}) / (mu_i + mu_o)
//       opposite sides:
//          K = W (e^{-x} - e^{-y}) / (mu_i - mu_o)   [-> W tau e^{-x}/mu^2 as mu_o -> mu_i]
//    (A: int e^{-sigma_t z (1/mu_i + 1/mu_o)} dz = d (1 - e^{-(x+y)})/(x+y); K: int
//    e^{-sigma_t z/mu_i} e^{-sigma_t (d-z)/mu_o} dz = d (e^{-x} - e^{-y})/(y - x); multiply by
//    sigma_s/(mu_i mu_o) and use d sigma_s = W tau.) A and K are symmetric in mu_i <-> mu_o.
// 3. Leaving. The radiance scattered towards the exit side (up for the BRDF) reaches the layer
//    boundary directly; the radiance scattered the other way first reflects off the far part
//    (D for the BRDF, with reflectance R_D(o)) and crosses the layer once more (t_o): factor
//    back = R_D(o) t_o. Then the radiance at the layer boundary, heading out, leaves through U
//    with the bounces between U and D summed and the n^2 law of radiance (Veach 1997 section
//    5.2; the slides' T^12 = (n_t/n_i)^2 (1-R)):
//       X = T_U(o) / (1 - R'_U(o) R_D(o) t_o^2) (n_out/n_k)^2,  n_out = n_above.
//    For the BTDF swap the roles of U and D: back = R'_U(o) t_o, X = T_D(o)/(same) (n_below/n_k)^2,
//    and mu_o follows Snell from wo in the medium below.
// 4. Phase function arguments. With h_i, h_o the horizontal parts of the propagation
//    directions inside layer k (h_i = -wi_xy n_above/n_k, h_o = wo_xy n_out/n_k) and
//    c_h = h_i . h_o, the incident beam goes (h_i, -mu_i) down or (h_i, +mu_i) up, the outgoing
//    (h_o, +-mu_o), so  p_minus = p(c_h - mu_i mu_o)  (one goes up, the other down) and
//    p_plus = p(c_h + mu_i mu_o)  (both the same way).
// Result, summing the four (incident down/up) x (outgoing direct/via the far side) paths:
//    f_r1,k = X [ (a + b back) p_minus A + (a back + b) p_plus K ]       (exit up)
//    f_t1,k = X [ (a + b back) p_plus  K + (a back + b) p_minus A ]      (exit down)
// and f = sum over layers. Check: one index-matched semi-infinite layer gives the classic
// single-scattering law of a semi-infinite medium, f_r1 = W p(cos)/(mu_i + mu_o) (the
// Lommel-Seeliger law with a phase function: Chandrasekhar, "Radiative Transfer", 1960; Hapke,
// J. Geophys. Res. 86:3039, 1981). The slides' semi-infinite term drops W, the Fresnel factors
// and p. Reciprocity: a(i) X(o) is symmetric up to the constant
// (n_out/n_k)^2 and swapping i <-> o maps the term a back p_plus K onto b p_plus K, so
// f_r1(wi, wo) = f_r1(wo, wi) and f_t1(wi -> wo)/n_below^2 = f_t1,flipped(wo -> wi)/n_above^2.
//
// Lambert substrate (albedo rho) under the last layer (no interface at the substrate: its
// medium is the last layer): one bounce off it, no volume scattering. The unscattered power
// reaching it is E T_S(i), T_S = the whole stack's transmittance to the substrate (zeroth
// order's reaches_substrate); it reflects radiance rho E T_S(i)/pi in the last layer's medium;
// that radiance leaves with T_S(o) (n_above/n_last)^2. Anything reflected back down by the
// interfaces would hit the substrate again (a second event), so it is not counted:
//    f_r1,substrate = rho/pi T_S(i) T_S(o) (n_above/n_last)^2.

namespace lamina {

namespace {

// A = (1 - e^{-(x+y)})/(mu_i + mu_o), without W. mu_i, mu_o > 0.
double same_side_integral(double tau, double mu_i, double mu_o) {
  if (tau == 0.0) return 0.0;
  const double s = tau / mu_i + tau / mu_o;  // inf for a semi-infinite layer: A = 1/(mu_i+mu_o)
  return -std::expm1(-s) / (mu_i + mu_o);
}

// K = (e^{-x} - e^{-y})/(mu_i - mu_o), x = tau/mu_i, y = tau/mu_o, without W; mu_i, mu_o > 0.
// 0/0 when mu_i = mu_o: with delta = |x - y| = tau |mu_i - mu_o|/(mu_i mu_o) and m = min(x, y),
//   K = e^{-m} [(1 - e^{-delta})/delta] tau/(mu_i mu_o),
// and (1 - e^{-delta})/delta = -expm1(-delta)/delta is accurate for every delta (-> 1 at 0).
// Where delta > 1 the direct form loses less than a digit and stays finite as mu -> 0.
double opposite_side_integral(double tau, double mu_i, double mu_o) {
  if (tau == 0.0 || std::isinf(tau)) return 0.0;  // no layer / the far side is at infinity
  const double x = tau / mu_i, y = tau / mu_o;
  const double delta = tau * std::abs(mu_i - mu_o) / (mu_i * mu_o);
  if (delta > 1.0) return (std::exp(-x) - std::exp(-y)) / (mu_i - mu_o);
  const double attenuation = std::exp(-std::min(x, y));
  if (attenuation == 0.0) return 0.0;  // x, y overflowed: avoid 0 * inf
  const double ratio = delta == 0.0 ? 1.0 : -std::expm1(-delta) / delta;
  return attenuation * ratio * (tau / mu_i) / mu_o;
}

enum class Exit { Top, Bottom };

using ChannelTransport = std::array<StackTransport, kChannels>;

// Calls term(t) for every layer and channel that scatters light from wi into wo, in channel
// order and within a channel in layer order (the order of the sums below). ti_rgb, to_rgb: the
// unscattered transport along wi (from above) and wo (on the exit side).
template <class Term>
void for_each_term(const LayerStack& stack, Exit exit, const ChannelTransport& ti_rgb, const ChannelTransport& to_rgb,
                   Term&& term) {
  const int n = static_cast<int>(stack.layers.size());
  const double n_out = exit == Exit::Top ? stack.above_ior : stack.below.ior;
  for (int c = 0; c < kChannels; ++c) {
    const StackTransport& ti = ti_rgb[c];
    const StackTransport& to = to_rgb[c];
    for (int k = 0; k < n; ++k) {
      const Layer& layer = stack.layers[k];
      const LayerTransport& li = ti.layers[k];
      const LayerTransport& lo = to.layers[k];
      if (li.mu <= 0.0 || lo.mu <= 0.0 || li.above.T == 0.0) continue;
      const double W = layer.albedo()[c];
      if (W == 0.0) continue;
      // Step 1: the unscattered beams in layer k.
      const double a = li.above.T / (1.0 - li.above.R_bottom * li.below.R_top * li.t * li.t);
      const double b = a * li.t * li.below.R_top;
      // Step 3: leaving towards the exit side.
      const double exit_T = exit == Exit::Top ? lo.above.T : lo.below.T;
      if (exit_T == 0.0) continue;
      const double far_R = exit == Exit::Top ? lo.below.R_top : lo.above.R_bottom;
      const double back = far_R * lo.t;
      const double eta = n_out / layer.ior;
      const double X = exit_T / (1.0 - lo.above.R_bottom * lo.below.R_top * lo.t * lo.t) * eta * eta;
      // Step 2: depth integrals.
      FirstOrderCosines::Term t;
      t.layer = k;
      t.channel = c;
      t.weight = W * X;
      t.direct = a + b * back;
      t.via_far = a * back + b;
      t.A = same_side_integral(li.tau, li.mu, lo.mu);
      t.K = opposite_side_integral(li.tau, li.mu, lo.mu);
      t.mu_product = li.mu * lo.mu;
      term(t);
    }
  }
}

// The Lambert substrate's single reflection (exit through the top only), per channel.
bool substrate_term(const LayerStack& stack, Exit exit, const ChannelTransport& ti_rgb, const ChannelTransport& to_rgb,
                    Spectrum* f) {
  if (exit != Exit::Top || stack.below.kind != Below::Kind::Lambert) return false;
  const double eta = stack.above_ior / stack.layers.back().ior;
  for (int c = 0; c < kChannels; ++c)
    (*f)[c] = stack.below.albedo[c] * kInvPi * ti_rgb[c].whole.T * to_rgb[c].whole.T * eta * eta;
  return true;
}

// A term's value: its weight times the phase function at the two scattering angles (Step 4;
// wi_wo_xy = wi.x wo.x + wi.y wo.y, the only dependence on azimuth).
double term_value(const LayerStack& stack, const FirstOrderCosines::Term& t, bool top, double n_out, double wi_wo_xy) {
  const Layer& layer = stack.layers[t.layer];
  const double c_h = -wi_wo_xy * stack.above_ior * n_out / (layer.ior * layer.ior);
  const double p_minus = layer.phase(t.channel, c_h - t.mu_product);
  const double p_plus = layer.phase(t.channel, c_h + t.mu_product);
  const double bracket = top ? t.direct * p_minus * t.A + t.via_far * p_plus * t.K
                             : t.direct * p_plus * t.K + t.via_far * p_minus * t.A;
  return t.weight * bracket;
}

Spectrum single_scattering(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo, Exit exit) {
  const ChannelTransport ti = unscattered_transport_rgb(stack, wi.z, Outside::Above);
  const ChannelTransport to = unscattered_transport_rgb(stack, wo.z, exit == Exit::Top ? Outside::Above : Outside::Below);
  const double n_out = exit == Exit::Top ? stack.above_ior : stack.below.ior;
  const double wi_wo_xy = wi.x * wo.x + wi.y * wo.y;
  double sum[kChannels] = {0.0, 0.0, 0.0};
  for_each_term(stack, exit, ti, to, [&](const FirstOrderCosines::Term& t) {
    sum[t.channel] += term_value(stack, t, exit == Exit::Top, n_out, wi_wo_xy);
  });
  Spectrum substrate, f;
  const bool lambert = substrate_term(stack, exit, ti, to, &substrate);
  for (int c = 0; c < kChannels; ++c) f[c] = lambert ? sum[c] + substrate[c] : sum[c];
  return f;
}

}  // namespace

Spectrum first_order_brdf(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo) {
  if (!(wi.z > 0.0) || !(wo.z > 0.0)) return Spectrum();
  return single_scattering(stack, wi, wo, Exit::Top);
}

Spectrum first_order_btdf(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo) {
  if (!(wi.z > 0.0) || !(wo.z < 0.0) || !stack.transmits()) return Spectrum();
  return single_scattering(stack, wi, wo, Exit::Bottom);
}

Spectrum first_order_bsdf(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo) {
  return wo.z >= 0.0 ? first_order_brdf(stack, wi, wo) : first_order_btdf(stack, wi, wo);
}

FirstOrderCosines first_order_cosines(const LayerStack& stack, double cos_i, double cos_o) {
  FirstOrderCosines out;
  out.cos_i = cos_i;
  out.cos_o = cos_o;
  const bool top = cos_o > 0.0;
  if (!(cos_i > 0.0) || !(top || (cos_o < 0.0 && stack.transmits()))) return out;  // f = 0
  const Exit exit = top ? Exit::Top : Exit::Bottom;
  const ChannelTransport ti = unscattered_transport_rgb(stack, cos_i, Outside::Above);
  const ChannelTransport to = unscattered_transport_rgb(stack, cos_o, top ? Outside::Above : Outside::Below);
  for_each_term(stack, exit, ti, to, [&](const FirstOrderCosines::Term& t) { out.terms.push_back(t); });
  out.has_substrate = substrate_term(stack, exit, ti, to, &out.substrate);
  return out;
}

Spectrum first_order_bsdf(const LayerStack& stack, const FirstOrderCosines& cosines, const glm::dvec3& wi,
                          const glm::dvec3& wo) {
  const bool top = cosines.cos_o > 0.0;
  const double n_out = top ? stack.above_ior : stack.below.ior;
  const double wi_wo_xy = wi.x * wo.x + wi.y * wo.y;
  double sum[kChannels] = {0.0, 0.0, 0.0};
  for (const FirstOrderCosines::Term& t : cosines.terms) sum[t.channel] += term_value(stack, t, top, n_out, wi_wo_xy);
  Spectrum f;
  for (int c = 0; c < kChannels; ++c) f[c] = cosines.has_substrate ? sum[c] + cosines.substrate[c] : sum[c];
  return f;
}

namespace {

// P_n(x) by the three-term recurrence j P_j = (2j - 1) x P_{j-1} - (j - 1) P_{j-2}, and its
// derivative P_n'(x) = n (x P_n - P_{n-1})/(x^2 - 1) (|x| < 1; Abramowitz & Stegun 22.7.10, 22.8.5).
double legendre_p(int n, double x, double* derivative) {
  double p0 = 1.0, p1 = x;
  for (int j = 2; j <= n; ++j) {
    const double p2 = ((2.0 * j - 1.0) * x * p1 - (j - 1.0) * p0) / j;
    p0 = p1;
    p1 = p2;
  }
  *derivative = n * (x * p1 - p0) / (x * x - 1.0);
  return p1;
}

}  // namespace

GaussLegendreRule::GaussLegendreRule(int n) : n_(n) {
  // Roots of P_n by Newton from the usual initial guess cos(pi (i + 3/4)/(n + 1/2)); weight
  // 2/((1 - x^2) P_n'(x)^2). The roots are symmetric, so only half are kept.
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      const double p = legendre_p(n, x, &dp);
      const double dx = p / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    legendre_p(n, x, &dp);  // the derivative at the converged root
    root_.push_back(x);
    weight_.push_back(2.0 / ((1.0 - x * x) * dp * dp));
  }
}

void GaussLegendreRule::apply(double a, double b, double* nodes, double* weights) const {
  const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
  for (std::size_t i = 0; i < root_.size(); ++i) {
    const double x = root_[i];
    nodes[i] = mid - half * x;
    nodes[n_ - 1 - i] = mid + half * x;
    weights[i] = weights[n_ - 1 - i] = half * weight_[i];
  }
}

void gauss_legendre(int n, double a, double b, double* nodes, double* weights) {
  GaussLegendreRule(n).apply(a, b, nodes, weights);
}

FirstOrderAlbedo first_order_albedo(const LayerStack& stack, double cos_theta_i, int n_mu, int n_phi) {
  FirstOrderAlbedo out;
  const double mu_i = std::clamp(cos_theta_i, 0.0, 1.0);
  if (mu_i == 0.0) return out;
  const glm::dvec3 wi{std::sqrt((1.0 - mu_i) * (1.0 + mu_i)), 0.0, mu_i};
  std::vector<double> x(n_mu), w(n_mu);
  gauss_legendre(n_mu, 0.0, 1.0, x.data(), w.data());
  const bool transmits = stack.transmits();
  const double dphi = 2.0 * kPi / n_phi;
  for (int j = 0; j < n_mu; ++j) {
    const double mu = x[j], sin_o = std::sqrt((1.0 - mu) * (1.0 + mu));
    for (int m = 0; m < n_phi; ++m) {
      const double phi = (m + 0.5) * dphi;
      const glm::dvec3 up{sin_o * std::cos(phi), sin_o * std::sin(phi), mu};
      // int f cos dw = int_0^1 dmu int_0^2pi dphi f mu
      out.R_diffuse += first_order_brdf(stack, wi, up) * (w[j] * dphi * mu);
      if (transmits)
        out.T_diffuse += first_order_btdf(stack, wi, {up.x, up.y, -mu}) * (w[j] * dphi * mu);
    }
  }
  return out;
}

FirstOrderAlbedo first_order_bihemispherical_albedo(const LayerStack& stack, int n_mu_i, int n_mu, int n_phi) {
  FirstOrderAlbedo out;
  std::vector<double> x(n_mu_i), w(n_mu_i);
  gauss_legendre(n_mu_i, 0.0, 1.0, x.data(), w.data());
  for (int j = 0; j < n_mu_i; ++j) {
    const FirstOrderAlbedo a = first_order_albedo(stack, x[j], n_mu, n_phi);
    out.R_diffuse += a.R_diffuse * (2.0 * x[j] * w[j]);
    out.T_diffuse += a.T_diffuse * (2.0 * x[j] * w[j]);
  }
  return out;
}

}  // namespace lamina
