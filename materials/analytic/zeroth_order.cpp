#include "materials/analytic/zeroth_order.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "materials/interfaces/fresnel.h"

namespace lamina {

SpecularElement add_elements(const SpecularElement& a, const SpecularElement& b) {
  // Bounces between A's underside and B's top form a geometric series with ratio R'_A R_B.
  // The ratio reaches 1 only when both reflect totally, and then T_A = T_B = 0 (a total
  // reflector transmits nothing, and T is the same from both sides), so every term that would be
  // 0/0 is exactly 0: guard on the numerators.
  const double denom = 1.0 - a.R_bottom * b.R_top;
  SpecularElement ab;
  ab.T = (a.T == 0.0 || b.T == 0.0) ? 0.0 : a.T * b.T / denom;
  ab.R_top = a.R_top + ((a.T == 0.0 || b.R_top == 0.0) ? 0.0 : a.T * a.T * b.R_top / denom);
  ab.R_bottom = b.R_bottom + ((b.T == 0.0 || a.R_bottom == 0.0) ? 0.0 : b.T * b.T * a.R_bottom / denom);
  return ab;
}

namespace {

// A smooth interface between a medium of index n_a (beam cosine mu_a) above and n_b (mu_b)
// below; a negative cosine means the beam cannot exist in that medium at this invariant.
SpecularElement interface_element(double mu_a, double n_a, double mu_b, double n_b) {
  SpecularElement e;
  if (mu_a >= 0.0 && mu_b >= 0.0) {
    // Fresnel reflectance is symmetric: R(mu_a; n_a -> n_b) = R(mu_b; n_b -> n_a).
    const double R = fresnel_dielectric(mu_a, n_a, n_b);
    e.R_top = e.R_bottom = R;
    e.T = 1.0 - R;
  } else {
    // Total internal reflection on the side where the beam exists; nothing crosses. (The side
    // where it does not exist carries no light, so its reflectance does not matter; 1 keeps
    // the element a valid total reflector.)
    e.R_top = e.R_bottom = 1.0;
    e.T = 0.0;
  }
  return e;
}

}  // namespace

std::array<StackTransport, kChannels> unscattered_transport_rgb(const LayerStack& stack, double cos_theta,
                                                                Outside side) {
  const int n = static_cast<int>(stack.layers.size());
  const bool lambert = stack.below.kind == Below::Kind::Lambert;
  if (side == Outside::Below && lambert)
    throw std::invalid_argument("unscattered_transport: no light comes from below a Lambert substrate");
  const double n_src = side == Outside::Above ? stack.above_ior : stack.below.ior;
  const double mu_src = std::min(1.0, std::abs(cos_theta));
  // Cosine in a medium of index n_j by Snell from the source medium (refracted_cos is exact for
  // equal indices and keeps relative precision at grazing angles); -1 where n_src sin > n_j.
  auto mu_in = [&](double n_j) { return refracted_cos(mu_src, n_src, n_j); };

  // Channel-independent: the cosines and the interfaces. iface[k] lies above layer k;
  // iface[n] is the bottom (what lies under the last layer).
  std::vector<double> mu(n);
  for (int k = 0; k < n; ++k) mu[k] = mu_in(stack.layers[k].ior);
  std::vector<SpecularElement> iface(n + 1);
  iface[0] = interface_element(mu_in(stack.above_ior), stack.above_ior, mu[0], stack.layers[0].ior);
  for (int k = 1; k < n; ++k)
    iface[k] = interface_element(mu[k - 1], stack.layers[k - 1].ior, mu[k], stack.layers[k].ior);
  if (stack.layers[n - 1].semi_infinite())
    iface[n] = {0.0, 0.0, 0.0};  // nothing comes back from infinity, nothing passes (t = 0 anyway)
  else if (lambert)
    iface[n] = {0.0, 0.0, 1.0};  // no interface: every unscattered beam reaches the substrate
  else
    iface[n] = interface_element(mu[n - 1], stack.layers[n - 1].ior, mu_in(stack.below.ior), stack.below.ior);

  std::array<StackTransport, kChannels> out;
  for (int c = 0; c < kChannels; ++c) {
    StackTransport& st = out[c];
    st.layers.resize(n);
    for (int k = 0; k < n; ++k) {
      LayerTransport& L = st.layers[k];
      L.mu = mu[k];
      L.tau = stack.layers[k].optical_depth(c);
      if (L.mu < 0.0) {
        L.t = 0.0;
        L.one_minus_t = 1.0;
      } else {
        // x = tau / mu: tau = 0 is exactly transparent even at mu = 0; mu = 0 with tau > 0
        // gives x = inf and t = 0; a semi-infinite layer has tau = inf and t = 0.
        const double x = L.tau == 0.0 ? 0.0 : L.tau / L.mu;
        L.t = std::exp(-x);
        L.one_minus_t = -std::expm1(-x);
      }
    }
    // Top-down: above[k] = interface 0 (+) layer 0 (+) interface 1 ... (+) interface k.
    st.layers[0].above = iface[0];
    for (int k = 1; k < n; ++k)
      st.layers[k].above = add_elements(add_elements(st.layers[k - 1].above, {0.0, 0.0, st.layers[k - 1].t}), iface[k]);
    // Bottom-up: below[k] = interface k+1 (+) layer k+1 (+) ... (+) the bottom.
    st.layers[n - 1].below = iface[n];
    for (int k = n - 2; k >= 0; --k)
      st.layers[k].below = add_elements(iface[k + 1], add_elements({0.0, 0.0, st.layers[k + 1].t}, st.layers[k + 1].below));
    st.whole = add_elements(add_elements(st.layers[n - 1].above, {0.0, 0.0, st.layers[n - 1].t}), iface[n]);
  }
  return out;
}

StackTransport unscattered_transport(const LayerStack& stack, int channel, double cos_theta, Outside side) {
  return std::move(unscattered_transport_rgb(stack, cos_theta, side)[channel]);
}

ZerothOrder zeroth_order(const LayerStack& stack, double cos_theta_i) {
  const int n = static_cast<int>(stack.layers.size());
  const bool lambert = stack.below.kind == Below::Kind::Lambert;
  ZerothOrder z;
  z.collided_in_layer.assign(n, Spectrum());
  z.cos_layer.assign(n, -1.0);
  const auto rgb = unscattered_transport_rgb(stack, cos_theta_i, Outside::Above);
  for (int c = 0; c < kChannels; ++c) {
    const StackTransport& st = rgb[c];
    z.R_specular[c] = st.whole.R_top;
    const bool transmits = stack.transmits();
    z.T_ballistic[c] = transmits ? st.whole.T : 0.0;
    if (lambert) z.reaches_substrate[c] = st.whole.T;
    double collided = z.reaches_substrate[c];
    for (int k = 0; k < n; ++k) {
      const LayerTransport& L = st.layers[k];
      z.cos_layer[k] = L.mu;
      if (L.above.T == 0.0) continue;
      // Steady state in layer k: the downward beam at its top has power
      //   a = T_above / (1 - R'_above R_below t^2)  (bounces between the parts above and below),
      // the upward beam at its bottom b = a t R_below. Each pass collides with probability 1 - t.
      const double a = L.above.T / (1.0 - L.above.R_bottom * L.below.R_top * L.t * L.t);
      const double b = a * L.t * L.below.R_top;
      const double hit = (a + b) * L.one_minus_t;
      z.collided_in_layer[k][c] = hit;
      collided += hit;
    }
    z.collided[c] = collided;
  }
  if (stack.transmits()) z.cos_below = refracted_cos(cos_theta_i, stack.above_ior, stack.below.ior);
  return z;
}

}  // namespace lamina
