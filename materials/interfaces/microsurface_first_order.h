// The energy-conserving microsurface's first order for one incoming direction, evaluated towards
// many outgoing ones (materials/interfaces/microsurface.h, MicrosurfaceDielectric::density_single).
#pragma once

#include <cmath>

#include <glm/vec3.hpp>

#include "materials/interfaces/microfacet.h"
#include "materials/interfaces/microsurface.h"

namespace lamina {

// The first order of one incoming direction `from` (MicrosurfaceDielectric::density_single and
// eval_single at a fixed `from`) for callers that evaluate it towards many directions (the
// adding-doubling projection's quadrature): what depends on `from` alone -- its frame, Lambda,
// projected area and the log-Gamma of the Beta function's first argument -- is computed once, and
// the Beta function once per distinct Lambda(to) in a row (the azimuths of one polar angle share
// it). The same numbers, bit for bit, as density_single and eval_single, which are this class.
class MicrosurfaceFirstOrder {
 public:
  MicrosurfaceFirstOrder(const MicrosurfaceDielectric& surface, const glm::dvec3& from);
  // P(to | from) of the walks of one scattering: density_single(from, to).
  double density(const glm::dvec3& to);
  // f(wo, from) of the first order: eval_single(wo, from).
  double eval(const glm::dvec3& wo) { return wo.z == 0.0 ? 0.0 : density(wo) / std::abs(wo.z); }

 private:
  GgxDistribution distribution_;
  bool grazing_;  // from.z == 0: nothing arrives
  double sign_, n_out_, n_in_;
  glm::dvec3 a_;               // from in the frame where it is on +z
  double lambda_a_, area_a_;   // Lambda(a) and the projected area seen from a
  double lgamma_a_ = 0.0;      // lgamma(1 + Lambda(a)), once a transmission needs it
  bool has_lgamma_a_ = false;
  double last_lambda_b_ = -1.0, last_beta_ = 0.0;  // the last Beta function, by its Lambda(to)
  double beta(double lambda_b);
};

}  // namespace lamina
