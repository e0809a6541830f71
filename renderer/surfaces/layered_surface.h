// How the path tracer scatters light at a layered material, per --subsurface mode.
//
// random-walk: not a Surface. The integrator (renderer/render/integrator.cpp) takes over the event: the
//   top interface's specular reflection is a delta lobe chosen with probability R(wo); otherwise
//   the materials/ random walk runs from the viewer's direction wo (reciprocity, below) and at
//   each scattering event the integrator samples a light and connects to it with
//   connection_weight(); the walk's exits continue the path. The helpers here are the pieces of
//   that estimator that do not touch the scene.
// first-order: FirstOrderSurface, the analytic zeroth order (delta lobes) and first order.
// table: TableSurface, a per-material BRDF/BTDF table from the walk (renderer/layered/layered_table.h).
// lambert: LambertSurface with LayeredMaterial::lambert_albedo().
//
// Reciprocity. The walk with incident direction wo estimates f(wo -> w). The path tracer needs
// f(w -> wo). Reflection is reciprocal: f_r(w -> wo) = f_r(wo -> w). Transmission between media
// of different index is not: f_t(wi -> wo) / n_o^2 = f_t(wo -> wi) / n_i^2 (Veach's thesis,
// eq. 5.19; n of the medium each direction lies in), so with wo above (n_above) and w below
// (n_below), f_t(w -> wo) = f_t(wo -> w) (n_above / n_below)^2: transmission_radiance_factor().
#pragma once

#include <algorithm>

#include <glm/vec3.hpp>

#include "materials/random_walk.h"
#include "materials/spectrum.h"
#include "materials/stack.h"
#include "materials/zeroth_order.h"
#include "renderer/surfaces/surface.h"

namespace lamina {

// (n_above / n_below)^2: multiplies every transmitted contribution (see above). 1 for a stack
// that does not transmit.
double transmission_radiance_factor(const LayerStack& stack);

// The walk's density of leaving straight from `event` along w, as used for MIS between the
// walk's own exits and light samples at events: the mean over the three channels of
// connection_pdf with that channel as the hero. Why not the walk's own hero: the walk's weights
// are already a balance over heroes (spectral MIS), and MIS weights between the exit and the
// light sample are unbiased for any weights that sum to 1 for each path AND do not depend on
// which hero drew it (then the hero average of each technique is the technique's full integral
// times its weight). The hero's own pdf breaks the second condition for coloured media.
double exit_pdf_for_mis(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w);

// The product of Fresnel transmissions (1 - R) of the interfaces a direct exit from `layer`
// towards the outside direction w crosses (0 where none refracts out to w). Only the naive
// estimator uses it, to remove the Fresnel factor from connection_weight.
double exit_fresnel_transmission(const LayerStack& stack, int layer, const glm::dvec3& w);

// The zeroth-order delta lobes that the first-order and table modes add, at the viewer's
// direction wo (local frame, wo.z > 0), and how a sample chooses between them and the diffuse
// rest by u_x: the mirror reflection R_specular(wo) with probability p_specular, then the
// ballistic transmission T_ballistic(wo) (times t_factor, above) with probability p_ballistic --
// the channels' means of those parts (contracts.md: R_specular + T_ballistic + collided = 1), so
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

// first-order mode: f = zeroth order (delta lobes) + first_order_brdf / first_order_btdf.
// Built per hit for the viewer direction wo (local frame, wo.z > 0; +z the stack's top).
// Sampling: the specular reflection R_specular(wo) and the ballistic transmission
// T_ballistic(wo) as delta lobes with probabilities equal to their mean over channels, else a
// cosine-weighted direction, on both sides with probability 1/2 each for a transmitting stack.
class FirstOrderSurface final : public Surface {
 public:
  FirstOrderSurface(const LayerStack& stack, const glm::dvec3& wo);
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  const LayerStack& stack_;
  ZerothOrderLobes lobes_;
};

}  // namespace lamina
