#include "materials/fit/spectral_fit.h"

#include <algorithm>
#include <cmath>
#include <regex>
#include <stdexcept>

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

LeafSpectra leaf_spectra(const std::vector<SpectralStack>& stacks, const std::vector<double>& nm,
                         const std::vector<double>& cos_theta_i, const std::vector<double>& weights,
                         const AddingDoublingSettings& settings) {
  if (cos_theta_i.empty() || cos_theta_i.size() != weights.size())
    throw std::invalid_argument("leaf_spectra: one weight per incidence, at least one");
  AddingDoublingSettings s = settings;
  s.only_channel = 0;  // each wavelength is a grey stack
  LeafSpectra out;
  out.r.assign(stacks.size(), std::vector<double>(nm.size(), 0.0));
  out.t = out.r;
  // In parallel over wavelengths, each into its own slots (the same numbers on any thread
  // count); one thread holds one wavelength's projections in the cache at a time.
  tbb::parallel_for(std::size_t{0}, nm.size(), [&](std::size_t i) {
    for (std::size_t k = 0; k < stacks.size(); ++k) {
      const LayerStack grey = stack_at_wavelength(stacks[k], nm[i]);
      for (std::size_t a = 0; a < cos_theta_i.size(); ++a) {
        const AddingDoublingTotals t = adding_doubling_totals(grey, cos_theta_i[a], s);
        out.r[k][i] += weights[a] * (t.R_specular[0] + t.R_diffuse[0]);
        out.t[k][i] += weights[a] * (t.T_ballistic[0] + t.T_diffuse[0]);
      }
    }
  });
  return out;
}

namespace {

// The fit's unknowns scaled to [0, 1] by their bounds (so that one tolerance serves all of them
// whatever their units) and the residuals model - measured at a quadrature order.
struct Problem {
  SpectralStack stack;
  std::vector<double*> targets;
  const std::vector<FitParameterSpec>* specs;
  const std::vector<double>* nm;
  const std::vector<double>* measured;
  double cos_theta_i;
  AddingDoublingSettings settings;  // the order of the current stage
  int evaluations = 0, coarse_evaluations = 0;
  bool coarse = false;

  void set(const std::vector<double>& u) {
    for (std::size_t k = 0; k < targets.size(); ++k) {
      const FitParameterSpec& p = (*specs)[k];
      *targets[k] = p.lower + std::clamp(u[k], 0.0, 1.0) * (p.upper - p.lower);
    }
  }
  std::vector<double> residuals(const std::vector<double>& u) {
    set(u);
    ++evaluations;
    if (coarse) ++coarse_evaluations;
    std::vector<double> r = modelled_reflectance(stack, *nm, cos_theta_i, settings);
    for (std::size_t i = 0; i < r.size(); ++i) r[i] -= (*measured)[i];
    return r;
  }
};

double sum_of_squares(const std::vector<double>& r) {
  double s = 0.0;
  for (double v : r) s += v * v;
  return s;
}

// Solves the symmetric positive definite system A x = b (n x n, row-major) by Cholesky
// (Golub and Van Loan, algorithm 4.2.1); false if A is not positive definite.
bool solve_spd(int n, std::vector<double> A, std::vector<double>* b) {
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < j; ++k) A[j * n + j] -= A[j * n + k] * A[j * n + k];
    if (!(A[j * n + j] > 0.0)) return false;
    A[j * n + j] = std::sqrt(A[j * n + j]);
    for (int i = j + 1; i < n; ++i) {
      for (int k = 0; k < j; ++k) A[i * n + j] -= A[i * n + k] * A[j * n + k];
      A[i * n + j] /= A[j * n + j];
    }
  }
  std::vector<double>& x = *b;
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < i; ++k) x[i] -= A[i * n + k] * x[k];
    x[i] /= A[i * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    for (int k = i + 1; k < n; ++k) x[i] -= A[k * n + i] * x[k];
    x[i] /= A[i * n + i];
  }
  return true;
}

// The Jacobian dr/du_k (column k) at u by forward differences of 1e-6 in u, towards the inside
// of the box: the residuals are smooth in the parameters, so the truncation error is ~1e-6 of
// the curvature, and the solver's rounding (~1e-12) / 1e-6 is far below the measurement's 1e-4.
std::vector<std::vector<double>> difference_jacobian(Problem& pb, const std::vector<double>& u,
                                                     const std::vector<double>& r) {
  std::vector<std::vector<double>> J(u.size());
  for (std::size_t k = 0; k < u.size(); ++k) {
    constexpr double h = 1e-6;
    std::vector<double> up = u;
    up[k] = u[k] + h <= 1.0 ? u[k] + h : u[k] - h;
    J[k] = pb.residuals(up);
    for (std::size_t i = 0; i < r.size(); ++i) J[k][i] = (J[k][i] - r[i]) / (up[k] - u[k]);
  }
  return J;
}

// The Gauss-Newton model of the sum of squares at u: A = J^T J (n x n, row-major), g = J^T r.
struct NormalEquations {
  int n = 0;
  std::vector<double> A, g;
  double largest = 0.0;  // the largest diagonal element of A
  NormalEquations(const std::vector<std::vector<double>>& J, const std::vector<double>& r)
      : n(static_cast<int>(J.size())), A(static_cast<std::size_t>(n) * n, 0.0), g(n, 0.0) {
    for (int a = 0; a < n; ++a) {
      for (std::size_t i = 0; i < r.size(); ++i) g[a] += J[a][i] * r[i];
      for (int b = 0; b < n; ++b)
        for (std::size_t i = 0; i < r.size(); ++i) A[a * n + b] += J[a][i] * J[b][i];
      largest = std::max(largest, A[a * n + a]);
    }
  }
  // The damped step d over the unknowns `free` (0 for the others): (A + mu D) d = -g, with D =
  // diag(A) floored at 1e-9 of its largest (Marquardt's scaling); false if that system is not
  // positive definite.
  bool step(const std::vector<int>& free, double mu, std::vector<double>* d) const {
    const int nf = static_cast<int>(free.size());
    std::vector<double> M(static_cast<std::size_t>(nf) * nf), x(nf);
    for (int a = 0; a < nf; ++a) {
      for (int b = 0; b < nf; ++b) M[a * nf + b] = A[free[a] * n + free[b]];
      M[a * nf + a] += mu * std::max(A[free[a] * n + free[a]], 1e-9 * largest);
      x[a] = -g[free[a]];
    }
    if (!solve_spd(nf, M, &x)) return false;
    d->assign(n, 0.0);
    for (int a = 0; a < nf; ++a) (*d)[free[a]] = x[a];
    return true;
  }
  // The decrease of the sum of squares the model predicts for a step s: -(2 s.g + s.A s).
  double predicted_decrease(const std::vector<double>& s) const {
    double p = 0.0;
    for (int a = 0; a < n; ++a) {
      p -= 2.0 * s[a] * g[a];
      for (int b = 0; b < n; ++b) p -= s[a] * A[a * n + b] * s[b];
    }
    return p;
  }
};

// Levenberg-Marquardt on the box [0, 1]^n (K. Madsen, H. B. Nielsen and O. Tingleff, "Methods
// for non-linear least squares problems", 2nd ed., DTU 2004, algorithm 3.16: Marquardt's
// damping of the Gauss-Newton step, and Nielsen's update of the damping mu from the gain ratio
// rho, the actual decrease over the predicted one). Bounds: a step is clamped into the box, and
// an unknown at a bound whose gradient points out of the box is held there for that iteration
// (the optimum is on the bound in that unknown). Stops when a step moves no unknown by more than
// `xtol`, when the sum of squares falls by less than 1e-10 of itself, when no damping finds a
// decrease (a minimum to rounding), or after `max_iterations` Jacobians. *damping: mu, carried
// from one call to the next (< 0: set from the first curvature).
void levenberg_marquardt(Problem& pb, std::vector<double>* u_io, double* damping, double xtol, int max_iterations) {
  std::vector<double>& u = *u_io;
  double& mu = *damping;
  std::vector<double> r = pb.residuals(u);
  double cost = sum_of_squares(r);
  double nu = 2.0;  // the damping's growth after a rejected step
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const NormalEquations ne(difference_jacobian(pb, u, r), r);
    std::vector<int> free;  // the unknowns not held at a bound
    for (int k = 0; k < ne.n; ++k)
      if (!((u[k] <= 0.0 && ne.g[k] > 0.0) || (u[k] >= 1.0 && ne.g[k] < 0.0))) free.push_back(k);
    if (free.empty() || !(ne.largest > 0.0)) return;
    if (mu < 0.0) mu = 1e-3 * ne.largest;
    for (bool accepted = false; !accepted;) {
      if (mu > 1e12 * ne.largest) return;  // no step decreases the sum: a minimum to rounding
      std::vector<double> d, trial = u, step(ne.n, 0.0);
      if (!ne.step(free, mu, &d)) {
        mu *= nu;
        nu *= 2.0;
        continue;
      }
      double moved = 0.0;
      for (int k : free) {
        trial[k] = std::clamp(u[k] + d[k], 0.0, 1.0);
        step[k] = trial[k] - u[k];
        moved = std::max(moved, std::abs(step[k]));
      }
      if (moved < xtol) return;
      std::vector<double> rt = pb.residuals(trial);
      const double trial_cost = sum_of_squares(rt);
      if (!(trial_cost < cost)) {
        mu *= nu;
        nu *= 2.0;
        continue;
      }
      const double predicted = ne.predicted_decrease(step);
      const double rho = predicted > 0.0 ? (cost - trial_cost) / predicted : 1.0;
      mu *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2.0;
      const bool stalled = cost - trial_cost < 1e-10 * cost;
      u = std::move(trial);
      r = std::move(rt);
      cost = trial_cost;
      if (stalled) return;
      accepted = true;
    }
  }
}

}  // namespace

// Levenberg-Marquardt (above) from the file's values (clamped into the bounds), first on a coarse
// model of `coarse_quadrature_points` (the search's many solutions at a fraction of the cost;
// its optimum is within the discretisation's shift of the accurate one), then on the accurate
// model from there, which has only that shift left to walk.
SpectralFitResult fit_spectrum(const SpectralStack& start, const std::vector<FitParameterSpec>& parameters,
                               const std::vector<double>& nm, const std::vector<double>& measured, double cos_theta_i,
                               const AddingDoublingSettings& settings, int coarse_quadrature_points) {
  if (parameters.empty() || parameters.size() > static_cast<std::size_t>(kMaxSpectralParameters))
    throw FitError("a spectral fit takes 1 to " + std::to_string(kMaxSpectralParameters) + " parameters");
  if (nm.empty() || nm.size() != measured.size()) throw FitError("the spectrum needs as many values as wavelengths");
  Problem pb{start, {}, &parameters, &nm, &measured, cos_theta_i, settings};
  pb.settings.only_channel = 0;
  const int n = static_cast<int>(parameters.size());
  std::vector<double> u(n);
  for (int k = 0; k < n; ++k) {
    const FitParameterSpec& p = parameters[k];
    if (!(p.lower < p.upper)) throw FitError(p.path + ": needs LO < HI");
    pb.targets.push_back(chromophore_parameter(&pb.stack, p.path));
    u[k] = std::clamp((*pb.targets.back() - p.lower) / (p.upper - p.lower), 0.0, 1.0);
  }
  // The damping is carried from the coarse search to the accurate one, whose curvature is nearly
  // the same: started afresh, the accurate search would first take the small steps of a new start.
  double damping = -1.0;
  if (coarse_quadrature_points >= 2 && coarse_quadrature_points < settings.quadrature_points) {
    pb.coarse = true;
    pb.settings.quadrature_points = coarse_quadrature_points;
    levenberg_marquardt(pb, &u, &damping, 1e-4, 100);
    pb.coarse = false;
    pb.settings.quadrature_points = settings.quadrature_points;
  }
  levenberg_marquardt(pb, &u, &damping, 1e-5, 100);
  pb.set(u);
  SpectralFitResult r;
  for (double* t : pb.targets) r.values.push_back(*t);
  r.nm = nm;
  r.measured = measured;
  r.modelled = modelled_reflectance(pb.stack, nm, cos_theta_i, settings);
  double sum = 0.0;
  for (std::size_t i = 0; i < nm.size(); ++i) sum += (r.modelled[i] - measured[i]) * (r.modelled[i] - measured[i]);
  r.rmse = std::sqrt(sum / static_cast<double>(nm.size()));
  r.evaluations = pb.evaluations + 1;
  r.coarse_evaluations = pb.coarse_evaluations;
  r.fitted = pb.stack;
  return r;
}

}  // namespace lamina
