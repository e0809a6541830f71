#include "renderer/batch/brdf_job.h"

#include <stdexcept>

#include "renderer/util/string_format.h"

namespace lamina {

bool parse_brdf_method(const std::string& name, BrdfMethod* method) {
  for (BrdfMethod m : {BrdfMethod::FirstOrder, BrdfMethod::MonteCarlo, BrdfMethod::AddingDoubling})
    if (name == brdf_method_name(m)) {
      *method = m;
      return true;
    }
  return false;
}

const char* brdf_method_name(BrdfMethod method) {
  switch (method) {
    case BrdfMethod::FirstOrder: return "first-order";
    case BrdfMethod::MonteCarlo: return "monte-carlo";
    case BrdfMethod::AddingDoubling: return "adding-doubling";
  }
  return "?";
}

namespace {

BrdfResult adding_doubling(const LayerStack& stack, const BrdfRequest& request) {
  const BrdfOptions& options = request.options;
  AddingDoublingSettings settings;
  settings.quadrature_points = request.quadrature_points;
  const double cos_theta_i = incident_direction(options.theta_i_deg, options.phi_i_deg).z;  // as the other methods
  BrdfResult result;
  result.adding_doubling = adding_doubling_with_error(stack, cos_theta_i, settings);
  result.has_table = request.table;
  if (!request.table) {
    result.table.options = options;
    return result;
  }
  // The table: every Fourier mode (materials/adding_doubling/adding_doubling.h). Say when
  // delta-M's truncation is too coarse for the bins (the totals are unaffected).
  const DeltaMTruncation tr = delta_m_truncation(stack, settings);
  if (tr.forward > 0.03)
    result.notes.push_back(string_printf(
        "at %d quadrature points delta-M puts %.0f%% of a scattering in the forward peak, which the table puts in the "
        "mirror/ballistic bin; raise --quadrature-points for the bins near it",
        request.quadrature_points, 100.0 * tr.forward));
  if (tr.backward > 1e-3)
    result.notes.push_back(string_printf(
        "a backward lobe (g < 0) is not resolved at %d quadrature points (%.1e of it beyond the series): its bins can "
        "be wrong, even negative; use --method monte-carlo for the table",
        request.quadrature_points, tr.backward));
  result.table = brdf_table_adding_doubling(stack, options, settings, &result.adding_doubling.totals);
  return result;
}

}  // namespace

void check_brdf_method(const LayerStack& stack, const std::string& source, BrdfMethod method) {
  if (method == BrdfMethod::FirstOrder && stack.rough_top())
    throw std::runtime_error(source + ": roughness: the first-order solution is for a smooth top interface; "
                             "use --method monte-carlo or adding-doubling");
  if (method == BrdfMethod::FirstOrder && stack.energy_conserving_rough())
    throw std::runtime_error(source + ": interface_model: the " + brdf_method_name(method) +
                             " solution has no energy-conserving rough interfaces; use --method monte-carlo or adding-doubling");
}

BrdfResult compute_brdf(const LayerStack& stack, const std::string& source, const BrdfRequest& request) {
  check_brdf_method(stack, source, request.method);
  if (request.method == BrdfMethod::AddingDoubling) return adding_doubling(stack, request);
  BrdfOptions options = request.options;
  // 'absorbed' is reported from conservation, photon by photon; the walk's direct tally of it
  // (EnergyTotals::absorbed_direct, a second estimator for the tests) is not printed.
  options.walk.tally_absorbed = false;
  BrdfResult result;
  result.table = request.method == BrdfMethod::FirstOrder ? brdf_table_first_order(stack, options)
                                                          : brdf_table_monte_carlo(stack, options);
  return result;
}

}  // namespace lamina
