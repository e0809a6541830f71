#include "renderer/batch/brdf_job.h"

#include <algorithm>
#include <limits>
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

std::vector<std::string> brdf_method_names() {
  std::vector<std::string> names;
  for (BrdfMethod m : {BrdfMethod::FirstOrder, BrdfMethod::MonteCarlo, BrdfMethod::AddingDoubling}) names.push_back(brdf_method_name(m));
  return names;
}

namespace {

BrdfOptionSpec real_option(const char* flag, const char* help, double* (*member)(BrdfRequest*), double lo, double hi,
                           bool lo_open = false, bool hi_open = false) {
  BrdfOptionSpec s{flag, help, BrdfOptionSpec::Kind::Real, lo, hi, lo_open, hi_open};
  s.real = member;
  return s;
}
BrdfOptionSpec integer_option(const char* flag, const char* help, int* (*member)(BrdfRequest*), double lo, double hi) {
  BrdfOptionSpec s{flag, help, BrdfOptionSpec::Kind::Integer, lo, hi};
  s.integer = member;
  return s;
}
BrdfOptionSpec count_option(const char* flag, const char* help, BrdfOptionSpec::Kind kind,
                            std::uint64_t* (*member)(BrdfRequest*), double lo = 0.0, double hi = 0.0) {
  BrdfOptionSpec s{flag, help, kind, lo, hi};
  s.count = member;
  return s;
}

constexpr double kInf = std::numeric_limits<double>::infinity();
// Limits of the counts: photons (a typo catcher, as lamina render's 1e12 paths) and bins.
constexpr double kMaxSamples = 1e12, kMaxBins = 10000;

}  // namespace

const std::vector<BrdfOptionSpec> kBrdfOptionTable = [] {
  std::vector<BrdfOptionSpec> t;
  BrdfOptionSpec theta = real_option("--theta-i", "incidence angle from the normal, degrees, in [0, 90)",
                                     [](BrdfRequest* r) { return &r->options.theta_i_deg; }, 0.0, 90.0, false, true);
  theta.required = true;
  t.push_back(theta);
  t.push_back(real_option("--phi-i", "azimuth of the light, degrees (default 0)",
                          [](BrdfRequest* r) { return &r->options.phi_i_deg; }, -kInf, kInf));
  t.push_back(BrdfOptionSpec{"--method", "first-order | monte-carlo | adding-doubling (default monte-carlo)",
                             BrdfOptionSpec::Kind::Method});
  t.push_back(integer_option("--quadrature-points",
                             "adding-doubling: Gauss nodes per cosine segment (default 16); the error estimate uses half",
                             [](BrdfRequest* r) { return &r->quadrature_points; }, 4, 128));
  t.push_back(count_option("--samples", "Monte Carlo photons (default 100000)", BrdfOptionSpec::Kind::Count,
                           [](BrdfRequest* r) { return &r->options.samples; }, 2, kMaxSamples));
  t.push_back(integer_option("--bins-theta", "K bins uniform in cos(theta_o) per hemisphere (default 18)",
                             [](BrdfRequest* r) { return &r->options.bins_theta; }, 1, kMaxBins));
  t.push_back(integer_option("--bins-phi", "M bins uniform in phi_o (default 36)",
                             [](BrdfRequest* r) { return &r->options.bins_phi; }, 1, kMaxBins));
  t.push_back(count_option("--seed", "random seed, 0 to 2^64-1 (default 1); results do not depend on threads",
                           BrdfOptionSpec::Kind::Seed, [](BrdfRequest* r) { return &r->options.seed; }));
  t.push_back(integer_option("--roulette-cap",
                             "interactions after which a walk survives each further one with probability 0.99 (default "
                             "1000000); raise it when 'unresolved' is not small against the errors",
                             [](BrdfRequest* r) { return &r->options.walk.forced_exponential_after; }, 1000, 2000000000));
  return t;
}();

std::string brdf_option_keyword(const BrdfOptionSpec& spec) {
  std::string k = std::string(spec.flag).substr(2);
  std::replace(k.begin(), k.end(), '-', '_');
  return k;
}

std::string brdf_option_text(const BrdfOptionSpec& spec, const BrdfRequest& request) {
  BrdfRequest r = request;
  switch (spec.kind) {
    case BrdfOptionSpec::Kind::Real: return string_printf("%.17g", *spec.real(&r));
    case BrdfOptionSpec::Kind::Integer: return std::to_string(*spec.integer(&r));
    case BrdfOptionSpec::Kind::Count:
    case BrdfOptionSpec::Kind::Seed: return std::to_string(*spec.count(&r));
    case BrdfOptionSpec::Kind::Method: return brdf_method_name(r.method);
  }
  return "";
}

void check_brdf_request(const BrdfRequest& request) {
  if (static_cast<long long>(request.options.bins_theta) * request.options.bins_phi > kMaxBrdfBinsTotal)
    throw std::invalid_argument("--bins-theta x --bins-phi must be at most " + std::to_string(kMaxBrdfBinsTotal));
}

namespace {

BrdfResult adding_doubling(const LayerStack& stack, const BrdfRequest& request) {
  const BrdfOptions& options = request.options;
  AddingDoublingSettings settings;
  settings.quadrature_points = request.quadrature_points;
  const double cos_theta_i = incident_direction(options.theta_i_deg, options.phi_i_deg).z;  // as the other methods
  BrdfResult result;
  result.adding_doubling = adding_doubling_with_error(stack, cos_theta_i, settings);
  if (result.adding_doubling.extrapolated)
    result.notes.push_back(string_printf(
        "at %d quadrature points delta-M puts %.0f%% of a scattering in the forward peak: the discretisation error "
        "is extrapolated from %d, %d and %d points (it falls slowly); raise --quadrature-points to shrink it",
        request.quadrature_points / 2, 100.0 * result.adding_doubling.forward_truncation, request.quadrature_points,
        std::max(2, request.quadrature_points / 2), std::max(2, request.quadrature_points / 4)));
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
  if (method == BrdfMethod::FirstOrder && stack.any_diffuse_interface())
    throw std::runtime_error(source + ": " + stack.first_diffuse_interface_path() +
                             ": the first-order solution has no diffuse interfaces; use --method monte-carlo or adding-doubling");
  if (method == BrdfMethod::FirstOrder && stack.rough_top())
    throw std::runtime_error(source + ": roughness: the first-order solution is for a smooth top interface; "
                             "use --method monte-carlo or adding-doubling");
  if (method == BrdfMethod::FirstOrder && stack.energy_conserving_rough())
    throw std::runtime_error(source + ": interface_model: the " + brdf_method_name(method) +
                             " solution has no energy-conserving rough interfaces; use --method monte-carlo or adding-doubling");
}

BrdfResult compute_brdf(const LayerStack& stack, const std::string& source, const BrdfRequest& request) {
  check_brdf_request(request);
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
