#include "materials/walk/walk_estimator.h"

#include <algorithm>
#include <cmath>

#include "materials/interfaces/fresnel.h"

namespace lamina {

double transmission_radiance_factor(const LayerStack& stack) {
  if (!stack.transmits()) return 1.0;
  const double r = stack.above_ior / stack.below.ior;
  return r * r;
}

double exit_pdf_for_mis(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w, double guiding,
                        const glm::dvec3& inside_up) {
  if ((stack.single_scattering_top() || stack.energy_conserving_alpha(0) > 0.0) && w.z > 0.0) {
    ExitDirection exit;
    prepare_exit_through(stack, w, inside_up, &exit, guiding);
    return connect_direct(stack, event, exit).pdf_for_mis;
  }
  return connect_direct(stack, event, prepare_exit(stack, w, guiding)).pdf_for_mis;
}

}  // namespace lamina
