// The analytic single-scattering ("first-order") BRDF and BTDF of a layer stack.
//
// "First order" is defined as the part of the Monte Carlo random walk made of paths with exactly
// ONE scattering event: a volume scattering in some layer, or one reflection off a Lambert
// substrate. Before and after that event the light is unscattered and may be reflected any
// number of times by the Fresnel interfaces (all of them summed in closed form with the adding
// results of zeroth_order.h). The delta parts (R_specular, T_ballistic) are not included: see
// zeroth_order(). The derivation is in first_order.cpp.
//
// Conventions (docs/contracts.md): local frame with +z the outward normal of the top layer; wi points
// towards the light, wo towards the viewer, both unit vectors; f = dL_o / (L_i cos(theta_i)
// dw_i) in 1/sr, per RGB channel. Light comes from above (wi.z > 0); for light from below use
// flipped(stack) with the z components negated.
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

// Reflection: wi.z > 0, wo.z > 0. Returns 0 otherwise (and at wi.z == 0 or wo.z == 0).
Spectrum first_order_brdf(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo);

// Transmission: wi.z > 0, wo.z < 0 (wo in the medium below). 0 for a stack that does not
// transmit (Lambert substrate or semi-infinite layer), and for other signs of wi.z, wo.z.
Spectrum first_order_btdf(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo);

// Dispatches on the sign of wo.z.
Spectrum first_order_bsdf(const LayerStack& stack, const glm::dvec3& wi, const glm::dvec3& wo);

// first_order_bsdf in two steps: the parts that depend on the cosines of wi and wo alone (the
// unscattered beams' transport, the depth integrals, the Lambert substrate's term: most of the
// cost), then the phase functions at the azimuth of wi and wo. A caller that evaluates many
// directions sharing the cosines (brdf_table_first_order: every azimuth of a bin row) prepares
// them once; the value is the same, bit for bit.
struct FirstOrderCosines {
  // One layer's and channel's single scattering without its phase function: it adds
  // weight (direct p(c_h -+ mu_product) A + via_far p(c_h +- mu_product) K) (first_order.cpp).
  struct Term {
    int layer = 0, channel = 0;
    double weight = 0.0, direct = 0.0, via_far = 0.0, A = 0.0, K = 0.0, mu_product = 0.0;
  };
  double cos_i = 0.0, cos_o = 0.0;  // wi.z and wo.z (wo.z < 0: transmission)
  std::vector<Term> terms;          // by channel, then layer
  bool has_substrate = false;       // the Lambert substrate's term (reflection only)
  Spectrum substrate;
};
FirstOrderCosines first_order_cosines(const LayerStack& stack, double cos_i, double cos_o);
// = first_order_bsdf(stack, wi, wo) for wi.z = cosines.cos_i, wo.z = cosines.cos_o.
Spectrum first_order_bsdf(const LayerStack& stack, const FirstOrderCosines& cosines, const glm::dvec3& wi,
                          const glm::dvec3& wo);

// The single-scattering directional albedos for light arriving at cos(theta_i):
//   R_diffuse = int_{wo.z > 0} f_r1 |wo.z| dwo,   T_diffuse = int_{wo.z < 0} f_t1 |wo.z| dwo,
// by Gauss-Legendre quadrature in |cos(theta_o)| (n_mu nodes) and the midpoint rule in phi_o
// (n_phi points, spectrally accurate for the periodic integrand). Accurate to ~1e-6 for smooth
// lobes (|g| <~ 0.8) with the defaults; strongly forward lobes (g -> 1) need more nodes.
struct FirstOrderAlbedo {
  Spectrum R_diffuse;
  Spectrum T_diffuse;
};
FirstOrderAlbedo first_order_albedo(const LayerStack& stack, double cos_theta_i, int n_mu = 48,
                                    int n_phi = 96);

// Bihemispherical (white-sky) albedos: 2 int_0^1 albedo(mu_i) mu_i dmu_i, Gauss-Legendre in mu_i.
FirstOrderAlbedo first_order_bihemispherical_albedo(const LayerStack& stack, int n_mu_i = 24,
                                                    int n_mu = 48, int n_phi = 96);

// Nodes and weights of the n-point Gauss-Legendre rule on [a, b] (Newton on P_n; Numerical
// Recipes 3rd ed. section 4.6).
void gauss_legendre(int n, double a, double b, double* nodes, double* weights);

// The same rule with its roots on [-1, 1] found once: apply(a, b, ...) gives gauss_legendre(n, a,
// b, ...) bit for bit without the Newton iterations (for callers that need many intervals:
// the adding-doubling bins integrate over every bin ring, mode and incidence).
class GaussLegendreRule {
 public:
  explicit GaussLegendreRule(int n);
  void apply(double a, double b, double* nodes, double* weights) const;
  int size() const { return n_; }

 private:
  int n_;
  std::vector<double> root_, weight_;  // the first (n + 1) / 2 roots on [-1, 1] and their weights
};

}  // namespace lamina
