#include "materials/fit/spectral_fit.h"

#include <algorithm>
#include <cmath>
#include <regex>

#include <nlopt.h>
#include <tbb/parallel_for.h>

namespace lamina {

double* chromophore_parameter(SpectralStack* stack, const std::string& path) {
  static const std::regex re(R"(layers\[(\d+)\]\.chromophores\.(scattering\.)?(\w+))");
  std::smatch m;
  if (!std::regex_match(path, m, re)) throw FitError(path + ": expected layers[i].chromophores.KEY");
  const std::size_t i = std::stoul(m[1].str());
  if (i >= stack->chromophores.size() || !stack->chromophores[i])
    throw FitError(path + ": layers[" + m[1].str() + "] is not a layer given by chromophores");
  SkinChromophores& c = *stack->chromophores[i];
  const std::string key = m[3].str();
  if (m[2].matched) {
    if (key == "reduced_500") return &c.scattering.reduced_500;
    if (key == "f_rayleigh") return &c.scattering.f_rayleigh;
    if (key == "b_mie") return &c.scattering.b_mie;
    throw FitError(path + ": unknown scattering key (reduced_500, f_rayleigh, b_mie)");
  }
  for (const ChromophoreKey& k : chromophore_keys())  // materials/spectral/chromophores.h
    if (key == k.name) return &(c.*k.member);
  if (key == "g") return &c.g;
  throw FitError(path + ": unknown chromophore key (melanin, eumelanin, blood, oxygenation, water, fat, carotene, baseline, "
                        "g, scattering.reduced_500|f_rayleigh|b_mie)");
}

std::vector<double> modelled_reflectance(const SpectralStack& stack, const std::vector<double>& nm, double cos_theta_i,
                                         const AddingDoublingSettings& settings) {
  AddingDoublingSettings s = settings;
  s.only_channel = 0;  // each wavelength is a grey stack
  std::vector<double> r(nm.size());
  tbb::parallel_for(std::size_t{0}, nm.size(), [&](std::size_t i) {
    const AddingDoublingTotals t = adding_doubling_totals(stack_at_wavelength(stack, nm[i]), cos_theta_i, s);
    r[i] = t.R_specular[0] + t.R_diffuse[0];
  });
  return r;
}

namespace {

struct Problem {
  SpectralStack stack;
  std::vector<double*> targets;
  const std::vector<FitParameterSpec>* specs;
  const std::vector<double>* nm;
  const std::vector<double>* measured;
  double cos_theta_i;
  AddingDoublingSettings settings;
  int evaluations = 0;

  void set(const double* u) {
    for (std::size_t k = 0; k < targets.size(); ++k) {
      const FitParameterSpec& p = (*specs)[k];
      *targets[k] = p.lower + std::clamp(u[k], 0.0, 1.0) * (p.upper - p.lower);
    }
  }
  double sum_of_squares(const double* u) {
    set(u);
    ++evaluations;
    const std::vector<double> r = modelled_reflectance(stack, *nm, cos_theta_i, settings);
    double sum = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) sum += (r[i] - (*measured)[i]) * (r[i] - (*measured)[i]);
    return sum;
  }
};

double objective(unsigned, const double* u, double*, void* data) { return static_cast<Problem*>(data)->sum_of_squares(u); }

}  // namespace

// BOBYQA (Powell 2009) from the file's values (clamped into the bounds), initial step a tenth of
// each range; stops when the parameters move by less than 1e-4 of their ranges or after 500
// spectra.
SpectralFitResult fit_spectrum(const SpectralStack& start, const std::vector<FitParameterSpec>& parameters,
                               const std::vector<double>& nm, const std::vector<double>& measured, double cos_theta_i,
                               const AddingDoublingSettings& settings) {
  if (parameters.empty() || parameters.size() > static_cast<std::size_t>(kMaxSpectralParameters))
    throw FitError("a spectral fit takes 1 to " + std::to_string(kMaxSpectralParameters) + " parameters");
  if (nm.empty() || nm.size() != measured.size()) throw FitError("the spectrum needs as many values as wavelengths");
  Problem pb{start, {}, &parameters, &nm, &measured, cos_theta_i, settings};
  const int n = static_cast<int>(parameters.size());
  std::vector<double> u(n), lo(n, 0.0), hi(n, 1.0), steps(n, 0.1);
  for (int k = 0; k < n; ++k) {
    const FitParameterSpec& p = parameters[k];
    if (!(p.lower < p.upper)) throw FitError(p.path + ": needs LO < HI");
    pb.targets.push_back(chromophore_parameter(&pb.stack, p.path));
    u[k] = std::clamp((*pb.targets.back() - p.lower) / (p.upper - p.lower), 0.0, 1.0);
  }
  nlopt_opt opt = nlopt_create(NLOPT_LN_BOBYQA, static_cast<unsigned>(n));
  nlopt_set_lower_bounds(opt, lo.data());
  nlopt_set_upper_bounds(opt, hi.data());
  nlopt_set_initial_step(opt, steps.data());
  nlopt_set_min_objective(opt, objective, &pb);
  nlopt_set_xtol_abs1(opt, 1e-4);
  nlopt_set_maxeval(opt, 500);
  double best = 0.0;
  const nlopt_result status = nlopt_optimize(opt, u.data(), &best);
  nlopt_destroy(opt);
  if (status < 0 && status != NLOPT_ROUNDOFF_LIMITED)
    throw FitError("the optimiser failed (NLopt status " + std::to_string(static_cast<int>(status)) + ")");
  pb.set(u.data());
  SpectralFitResult r;
  for (double* t : pb.targets) r.values.push_back(*t);
  r.nm = nm;
  r.measured = measured;
  r.modelled = modelled_reflectance(pb.stack, nm, cos_theta_i, settings);
  double sum = 0.0;
  for (std::size_t i = 0; i < nm.size(); ++i) sum += (r.modelled[i] - measured[i]) * (r.modelled[i] - measured[i]);
  r.rmse = std::sqrt(sum / static_cast<double>(nm.size()));
  r.evaluations = pb.evaluations + 1;
  r.fitted = pb.stack;
  return r;
}

}  // namespace lamina
