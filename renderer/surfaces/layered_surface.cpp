#include "renderer/surfaces/layered_surface.h"

#include <algorithm>
#include <cmath>

#include "materials/first_order.h"
#include "materials/fresnel.h"
#include "materials/sampling.h"

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

ZerothOrderLobes::ZerothOrderLobes(const LayerStack& stack, const glm::dvec3& wo)
    : zeroth(zeroth_order(stack, std::clamp(wo.z, 0.0, 1.0))), t_factor(transmission_radiance_factor(stack)),
      transmits(stack.transmits()), ior_ratio(stack.above_ior / stack.below.ior) {
  p_specular = std::clamp(zeroth.R_specular.average(), 0.0, 1.0);
  p_ballistic = transmits && zeroth.cos_below > 0.0 ? std::clamp(zeroth.T_ballistic.average(), 0.0, 1.0) : 0.0;
  p_diffuse = std::max(0.0, 1.0 - p_specular - p_ballistic);
}

bool ZerothOrderLobes::sample(const glm::dvec3& wo, double u_x, BsdfSample* s) const {
  if (u_x < p_specular) {
    // Mirror delta lobe: f |cos| / pdf = R_specular / p_specular (per delta).
    s->wi = {-wo.x, -wo.y, wo.z};
    s->pdf = p_specular;
    s->f = zeroth.R_specular / std::max(wo.z, 1e-300);
    s->delta = true;
    return true;
  }
  if (u_x < p_specular + p_ballistic) {
    // Ballistic delta lobe: the unscattered light from below that leaves towards wo; Snell
    // between the outside media: n_above sin(theta_o) = n_below sin(theta_b).
    s->wi = {-wo.x * ior_ratio, -wo.y * ior_ratio, -zeroth.cos_below};
    s->pdf = p_ballistic;
    s->f = zeroth.T_ballistic * t_factor / zeroth.cos_below;
    s->delta = true;
    return true;
  }
  return false;
}

FirstOrderSurface::FirstOrderSurface(const LayerStack& stack, const glm::dvec3& wo) : stack_(stack), lobes_(stack, wo) {}

Spectrum FirstOrderSurface::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z <= 0.0) return Spectrum(0.0);
  // Reflection is reciprocal: f_r(wi -> wo) = first_order_brdf(light at wi, viewer at wo).
  if (wi.z > 0.0) return first_order_brdf(stack_, wi, wo);
  // Transmission: the library gives f_t(wo -> wi) (light from above at wo); reciprocity with
  // indices (layered_surface.h) turns it into f_t(wi -> wo).
  if (wi.z < 0.0 && lobes_.transmits) return first_order_btdf(stack_, wo, wi) * lobes_.t_factor;
  return Spectrum(0.0);
}

double FirstOrderSurface::pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z <= 0.0 || wi.z == 0.0) return 0.0;
  if (wi.z < 0.0 && !lobes_.transmits) return 0.0;
  return lobes_.p_diffuse * std::abs(wi.z) * kInvPi * (lobes_.transmits ? 0.5 : 1.0);
}

bool FirstOrderSurface::sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const {
  if (wo.z <= 0.0) return false;
  if (lobes_.sample(wo, u.x, s)) return true;
  if (lobes_.p_diffuse <= 0.0) return false;
  const double v = lobes_.diffuse_u(u.x);
  glm::dvec3 w;
  if (lobes_.transmits) {
    // Both sides with probability 1/2: reuse v.
    const bool down = v < 0.5;
    w = sample_cosine_hemisphere({down ? 2.0 * v : 2.0 * v - 1.0, u.y});
    if (down) w.z = -w.z;
  } else {
    w = sample_cosine_hemisphere({v, u.y});
  }
  return complete_sample(*this, wo, w, s);
}

}  // namespace lamina
