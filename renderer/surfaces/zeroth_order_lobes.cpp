#include "renderer/surfaces/zeroth_order_lobes.h"

#include "materials/walk/walk_estimator.h"

namespace lamina {

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

}  // namespace lamina
