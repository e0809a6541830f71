#include "materials/walk_estimator.h"

#include <algorithm>
#include <cmath>

#include "materials/fresnel.h"

namespace lamina {

double transmission_radiance_factor(const LayerStack& stack) {
  if (!stack.transmits()) return 1.0;
  const double r = stack.above_ior / stack.below.ior;
  return r * r;
}

double exit_pdf_for_mis(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w) {
  ScatterEvent e = event;
  double sum = 0.0;
  for (int k = 0; k < kChannels; ++k) {
    e.hero = k;
    sum += connection_pdf(stack, e, w);
  }
  return sum / kChannels;
}

double exit_fresnel_transmission(const LayerStack& stack, int layer, const glm::dvec3& w) {
  // Snell keeps n sin(theta): the cosine in layer j follows from w (as in random_walk.cpp).
  if (!(w.z != 0.0)) return 0.0;
  const bool up = w.z > 0.0;
  if (!up && !stack.transmits()) return 0.0;
  const double n_out = up ? stack.above_ior : stack.below.ior;
  const double sin2_out = std::max(0.0, 1.0 - w.z * w.z);
  auto mu_in = [&](int j) {
    const double r = n_out / stack.layers[j].ior;
    const double s2 = r * r * sin2_out;
    return s2 < 1.0 ? std::sqrt(1.0 - s2) : -1.0;
  };
  const int n = static_cast<int>(stack.layers.size());
  double t = 1.0;
  if (up) {
    for (int k = layer; k >= 0; --k) {
      const double mu = mu_in(k);
      if (mu <= 0.0) return 0.0;
      t *= 1.0 - fresnel_dielectric(mu, stack.layers[k].ior, stack.ior_above_interface(k));
    }
  } else {
    for (int k = layer + 1; k <= n; ++k) {
      const double mu = mu_in(k - 1);
      if (mu <= 0.0) return 0.0;
      t *= 1.0 - fresnel_dielectric(mu, stack.layers[k - 1].ior, stack.ior_below_interface(k));
    }
  }
  return t;
}

}  // namespace lamina
