// The zeroth-order (unscattered) part of a layered surface as delta lobes, shared by the
// first-order and table surfaces.
#pragma once

#include <algorithm>

#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"
#include "materials/analytic/zeroth_order.h"
#include "renderer/surfaces/surface.h"

namespace lamina {

// The zeroth-order delta lobes that the first-order and table modes add, at the viewer's
// direction wo (local frame, wo.z > 0), and how a sample chooses between them and the diffuse
// rest by u_x: the mirror reflection R_specular(wo) with probability p_specular, then the
// ballistic transmission T_ballistic(wo) (times t_factor, above) with probability p_ballistic --
// the channels' means of those parts (docs/contracts.md: R_specular + T_ballistic + collided = 1), so
// a lobe of weight w is chosen with probability ~ w -- and the diffuse part with p_diffuse.
struct ZerothOrderLobes {
  ZerothOrderLobes(const LayerStack& stack, const glm::dvec3& wo);
  // True, with s filled, if u_x chose a delta lobe; false to sample the diffuse part, whose
  // random number is then diffuse_u(u_x), uniform in [0, 1).
  bool sample(const glm::dvec3& wo, double u_x, BsdfSample* s) const;
  double diffuse_u(double u_x) const { return std::min((u_x - p_specular - p_ballistic) / p_diffuse, 1.0 - 1e-16); }

  ZerothOrder zeroth;
  double t_factor = 1.0;   // transmission_radiance_factor(stack)
  bool transmits = false;  // stack.transmits()
  double ior_ratio = 1.0;  // n_above / n_below, for Snell between the outside media
  double p_specular = 0.0, p_ballistic = 0.0, p_diffuse = 1.0;
};

}  // namespace lamina
