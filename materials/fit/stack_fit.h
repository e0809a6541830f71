// The inverse problem (`lamina fit`): the parameters of a material file that best explain
// measured totals (reflectance and transmittance of a sample, as an integrating sphere gives
// them), by weighted least squares on the adding-doubling forward model
// (materials/adding_doubling/adding_doubling.h), with NLopt as the optimiser.
//
// Parameters are addressed by the paths of materials/stack/stack_parameters.h (the ones texture
// bindings use, e.g. "layers[0].components[1].fraction", "layers[0].sigma_s"), resolved by
// parse_stack_parameter and applied by apply_parameters: no second resolver.
//
// Per channel: the layered model is RGB, and the transport in one channel does not see the
// others, so a colour parameter (sigma_a, sigma_s, g, below.lambert) is fitted as one unknown
// per channel, PATH[r], PATH[g], PATH[b], each from the measurements of its own channel (a
// coloured coefficient is what a user wants from coloured data). A channel with no measurement
// keeps the file's value and is not an unknown. A scalar parameter (thickness, ior, fraction) is
// one unknown shared by all channels. All unknowns are fitted together.
//
// Measurements: totals for light from above, collimated at theta_i or uniform diffuse:
//   R               all reflected light (specular included): R_specular + R_diffuse, or
//                   R_hemispherical for diffuse incidence
//   R_diffuse       reflected light without the specular reflection (collimated only)
//   T               all transmitted light: T_ballistic + T_diffuse, or T_hemispherical
//   T_diffuse       transmitted light without the unscattered beam (collimated only)
//   T_unscattered   the unscattered beam T_ballistic (collimated only)
// and the bins of a BRDF/BTDF table (parse_fit_table: `lamina brdf`'s CSV, the model being the
// adding-doubling table on the same bins, which unlike R and T sees the phase function's shape),
// each with its 1-sigma uncertainty (Gaussian errors, independent).
//
// Fit: minimise chi^2(x) = sum_i ((m_i(x) - y_i) / s_i)^2 over the box of the bounds (NLopt's
// BOBYQA on the unknowns scaled to [0, 1]). Uncertainties: the covariance of the linearised
// least-squares estimate, C = (J^T W J)^-1 with W = diag(1/s_i^2) and J the Jacobian of the
// model at the optimum by central finite differences (one-sided at a bound); sigma_k =
// sqrt(C_kk) (Press et al., Numerical Recipes, 3rd ed., sec. 15.5, eq. 15.5.15: the curvature
// matrix alpha = J^T W J, C = alpha^-1). Not rescaled by chi^2/dof: the stated uncertainties are
// taken as the truth, so chi^2/dof near 1 is the check that they are.
// Identifiability: alpha is scaled to unit diagonal (a correlation-like matrix, so units do not
// matter) and its eigenvalues computed; a zero diagonal means the data do not depend on that
// unknown, and an eigenvalue below kIdentifiabilityThreshold means a combination of unknowns is
// not determined (e.g. sigma_s and g of a slab from R and T alone: both act mainly through
// sigma_s (1 - g), the similarity relation, van de Hulst 1980 ch. 14); the unknowns with more
// than 1% of that eigenvector are named, and their sigmas are reported as infinite (the others'
// sigmas are those of the pseudo-inverse: the combination barely moves them).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/stack/stack_parameters.h"

namespace lamina {

struct FitError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct FitParameterSpec {
  std::string path;
  double lower = 0.0, upper = 0.0;
};

// kBin: one bin of a BRDF/BTDF table (the `value` of `lamina brdf`'s table: the non-delta BRDF
// or BTDF averaged over the bin weighted by projected solid angle, 1/sr), collimated incidence.
enum class FitQuantity { kR, kRDiffuse, kT, kTDiffuse, kTUnscattered, kBin };

struct FitMeasurement {
  FitQuantity quantity = FitQuantity::kR;
  int channel = 0;              // 0, 1, 2 = r, g, b
  bool diffuse = false;         // uniform diffuse incidence (theta_i_deg unused)
  double theta_i_deg = 0.0;     // collimated incidence, in [0, 90)
  double value = 0.0, sigma = 0.0;
  std::string where;            // "FILE: line N", for messages
  // kBin only: the bin (side 0 reflect, 1 transmit; k of bins_theta in |cos theta_o|, m of
  // bins_phi in phi_o from the light's azimuth), as materials/brdf/brdf_table.h numbers them.
  int side = 0, bin_theta = 0, bin_phi = 0, bins_theta = 0, bins_phi = 0;
};

// The range of a measurement's value and sigma (each bin's combined sigma for a table), both
// typos far beyond any reflectance, transmittance or BRDF in 1/sr: within them every residual
// (model - value) / sigma, its square and chi^2 stay finite (at most ~1e36 a measurement), and
// so does every weight 1 / sigma^2.
constexpr double kMaxFitValue = 1e6;
constexpr double kMinFitSigma = 1e-12, kMaxFitSigma = 1e6;

// Reads the measurement CSV (docs/contracts.md "lamina fit"): a header with the columns
// quantity,channel,theta_i_deg,value,sigma (any order, extra columns are an error), then one row
// per measurement; channel is r, g or b; theta_i_deg is a number in [0, 90) or "diffuse"; value
// in [-kMaxFitValue, kMaxFitValue], sigma in [kMinFitSigma, kMaxFitSigma]; every number in the
// decimal notation of materials/stack/decimal.h. Throws FitError("FILE: line N: reason") (or "FILE: reason" for the file as a whole).
std::vector<FitMeasurement> parse_fit_measurements(const std::string& text, const std::string& source_name);
std::vector<FitMeasurement> load_fit_measurements(const std::string& path);

// Reads a BRDF/BTDF table in `lamina brdf`'s CSV format (docs/contracts.md "lamina brdf": the
// header side,channel,theta_o_deg,phi_o_deg,value,stderr[,single,multiple] in any order, one row
// per bin and channel) as kBin measurements for light at theta_i_deg (phi_o from the light's
// azimuth, as lamina brdf writes it). The grid, K x M, is that of the distinct theta_o and phi_o
// values, each of which must be a bin centre of it (acos((k + 1/2) / K), (m + 1/2) 360 / M
// degrees, to 1e-6 degree); a subset of the bins may be given as long as every ring and every
// azimuth appears. Each bin's sigma is sqrt(stderr^2 + sigma_floor^2) (the table's own
// standard error, and a floor for what it leaves out, e.g. a measurement's calibration); it
// must be in [kMinFitSigma, kMaxFitSigma], the value as above. Throws FitError("FILE: line N: reason").
std::vector<FitMeasurement> parse_fit_table(const std::string& text, const std::string& source_name, double theta_i_deg,
                                            double sigma_floor);

// One unknown of the fit: a parameter, or one channel of a colour parameter.
struct FitUnknown {
  int parameter = 0;  // index into the parameter specs
  int channel = -1;   // -1: a scalar parameter (all channels); else the channel of a colour
  std::string name;   // "PATH" or "PATH[r]"
  double lower = 0.0, upper = 0.0, start = 0.0;
};

struct FitSettings {
  // The forward model's quadrature: 16 points (adding-doubling's default). At 8 points the
  // totals can be off by 1e-4 to 4e-4 for g >= 0.85 (delta-M at order 8), a third of a typical
  // sphere's sigma of 1e-3; the check below says when that matters.
  AddingDoublingSettings forward{16};
  // The optimiser's search runs on a coarse forward model of this many points, corrected towards
  // `forward` by a few accurate solutions (defect correction, stack_fit.cpp fit_group), which
  // reaches the accurate model's optimum (the result agrees with a search on `forward` alone to
  // ~3e-3 sigma, tests/materials/fit/test_stack_fit.cpp) at a fraction of the cost
  // (docs/performance.md, "Fitting": a slab from R and T in ~5 ms instead of ~27 ms at 16 points). 0, or not below
  // forward.quadrature_points: the search uses `forward` itself.
  int coarse_quadrature_points = 4;
  // At most this many corrections (each one accurate solution and a short coarse search); a
  // correction that has not settled by then (the accurate model still moving by 0.01 sigma) is
  // a warning.
  int max_corrections = 8;
  // After the fit, compare the model at twice the points: a measurement whose value moves by
  // more than 0.2 of its sigma gets a warning (the discretisation biases the fit). Twice the
  // points are solved only if half the points move a value by more than 0.2 sigma (a screen:
  // stack_fit.cpp).
  bool check_discretisation = true;
  // Stopping rules (NLopt): the scaled unknowns move by less than relative_tolerance, or chi^2
  // by less than chi2_tolerance between steps. chi^2 - min chi^2 = d^2 for an unknown d sigmas
  // from its optimum (a quadratic near it), so 1e-6 stops within ~1e-3 sigma.
  double relative_tolerance = 1e-7;
  double chi2_tolerance = 1e-6;
  int max_evaluations = 2000;
};

// Below this eigenvalue of the unit-diagonal curvature matrix a combination of unknowns counts
// as not identified: its variance would be more than 1e8 times that of an unknown measured alone
// (a relative sigma of 1e4 times), which no measurement budget closes.
constexpr double kIdentifiabilityThreshold = 1e-8;

struct FitResult {
  std::vector<FitUnknown> unknowns;
  std::vector<double> value, sigma;        // per unknown; sigma infinite if not identified
  std::vector<bool> at_bound;              // the optimum lies on a bound (sigma then one-sided)
  std::vector<std::vector<double>> covariance;
  std::vector<double> model, residual;     // per measurement: m_i and (m_i - y_i) / s_i
  double chi2 = 0.0;
  int dof = 0;                             // measurements - unknowns
  int evaluations = 0;                     // forward-model solutions (optimiser and Jacobian)
  int coarse_evaluations = 0;              // of which on the coarse model (FitSettings)
  std::vector<std::string> warnings;       // one line each: identifiability, bounds
  std::vector<Spectrum> parameter_values;  // per parameter spec: the fitted value (colours whole)
  LayerStack stack;                        // the template's stack with the fitted values
};

// Rough interfaces (either interface model) are in the forward model: adding-doubling projects
// each onto its basis once (interface_fourier.h's cache), and every evaluation after the first
// costs what a smooth stack's does plus the beams' first order (docs/fitting.md, "Rough
// interfaces"). What would change the projection at every evaluation is not fitted: the
// roughness itself, and an index on a stack with rough interfaces. Returns that refusal for
// `p` (one line naming its path), or an empty string.
std::string rough_projection_refusal(const StackTemplate& t, const StackParameter& p);

// Fits `specs` of the template to `data`. Throws FitError (one line) for a bad path (the
// resolver's message), reversed or non-finite bounds, bounds outside the parameter's physical
// range, a parameter rough_projection_refusal refuses, no measurements, or an unknown with no
// measurement in its channel.
FitResult fit_stack(const StackTemplate& t, const std::vector<FitParameterSpec>& specs,
                    const std::vector<FitMeasurement>& data, const FitSettings& settings = {});

// The model's values of `data` for a stack (what the fit compares with the measurements).
std::vector<double> fit_model_values(const LayerStack& stack, const std::vector<FitMeasurement>& data,
                                     const AddingDoublingSettings& settings = {});

// The material file's JSON with the fitted values written at their paths (find_stack_value):
// colours as RGB triples, a fraction with the layer's other fractions rescaled as
// apply_parameters does, so that parsing the result gives result.stack.
void write_fitted_values(nlohmann::json& stack_json, const StackTemplate& t, const std::vector<FitParameterSpec>& specs,
                         const FitResult& result);

}  // namespace lamina
