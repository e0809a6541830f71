#include "renderer/surfaces/first_order_surface.h"

#include <cmath>

#include "materials/analytic/first_order.h"
#include "materials/base/sampling.h"

namespace lamina {

FirstOrderSurface::FirstOrderSurface(const LayerStack& stack, const glm::dvec3& wo) : stack_(stack), lobes_(stack, wo) {}

Spectrum FirstOrderSurface::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z <= 0.0) return Spectrum(0.0);
  // Reflection is reciprocal: f_r(wi -> wo) = first_order_brdf(light at wi, viewer at wo).
  if (wi.z > 0.0) return first_order_brdf(stack_, wi, wo);
  // Transmission: the library gives f_t(wo -> wi) (light from above at wo); reciprocity with
  // indices (materials/walk/walk_estimator.h) turns it into f_t(wi -> wo).
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
