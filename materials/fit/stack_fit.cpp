#include "materials/fit/stack_fit.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include <nlohmann/json.hpp>
#include <nlopt.h>
#include <tbb/parallel_for.h>

#include "materials/stack/decimal.h"
#include "materials/stack/text_file.h"

namespace lamina {

namespace {

const char* const kChannelNames[kChannels] = {"r", "g", "b"};

std::string number_text(double v) {
  std::ostringstream os;
  os.precision(9);
  os << v;
  return os.str();
}

// Splits one CSV line at commas, trimming blanks around fields (no quoting: the fields are
// names and numbers).
std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    std::string f = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const std::size_t a = f.find_first_not_of(" \t\r"), b = f.find_last_not_of(" \t\r");
    out.push_back(a == std::string::npos ? std::string() : f.substr(a, b - a + 1));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

// The fields of line `line_no` of a measurement CSV, after checking that it is text (a binary file
// given by mistake fails here, naming the byte).
std::vector<std::string> csv_fields(const std::string& line, const std::string& source, int line_no) {
  for (unsigned char ch : line)
    if ((ch < 0x20 && ch != '\t' && ch != '\r') || ch >= 0x7f)
      throw FitError(source + ": line " + std::to_string(line_no) + ": not text (byte " + std::to_string(ch) +
                     "): expected CSV");
  return split_csv_line(line);
}

// A CSV header: column name -> index. Every name must be one of `required` or `ignored`, none may
// repeat, every required one must be there; the errors end with `unknown_hint` / `missing_hint`.
std::map<std::string, int> csv_header(const std::vector<std::string>& f, const std::string& where,
                                      const std::vector<std::string>& required, const std::vector<std::string>& ignored,
                                      const std::string& unknown_hint, const std::string& missing_hint) {
  std::map<std::string, int> column;
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (std::find(required.begin(), required.end(), f[k]) == required.end() &&
        std::find(ignored.begin(), ignored.end(), f[k]) == ignored.end())
      throw FitError(where + ": unknown column '" + f[k] + "' (" + unknown_hint + ")");
    if (!column.emplace(f[k], static_cast<int>(k)).second) throw FitError(where + ": column '" + f[k] + "' twice");
  }
  for (const std::string& c : required)
    if (!column.count(c)) throw FitError(where + ": missing column '" + c + "' (" + missing_hint + ")");
  return column;
}

// What a CSV's header must be (csv_header's rules) and what to say when there is none.
struct CsvHeaderSpec {
  std::vector<std::string> required, ignored;
  std::string unknown_hint, missing_hint;
  std::string empty;  // the error after "SOURCE: " for a text without a header
};

// Reads a CSV text: blank lines are skipped, the first other line is the header (`spec`), and
// every further line, checked to have the header's number of fields, goes to
// on_row(fields, where, column) with where = "SOURCE: line N".
void read_csv_rows(const std::string& text, const std::string& source, const CsvHeaderSpec& spec,
                   const std::function<void(const std::vector<std::string>&, const std::string&,
                                            std::map<std::string, int>&)>& on_row) {
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  std::map<std::string, int> column;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> f = csv_fields(line, source, line_no);
    const std::string where = source + ": line " + std::to_string(line_no);
    if (column.empty()) {
      column = csv_header(f, where, spec.required, spec.ignored, spec.unknown_hint, spec.missing_hint);
      continue;
    }
    if (f.size() != column.size())
      throw FitError(where + ": " + std::to_string(f.size()) + " fields, the header has " + std::to_string(column.size()));
    on_row(f, where, column);
  }
  if (column.empty()) throw FitError(source + ": " + spec.empty);
}

// A finite decimal number, the whole field (materials/stack/decimal.h), in [lo, hi]; else throws
// naming the line and the column.
double parse_number(const std::string& field, const std::string& where, const std::string& column,
                    double lo = -std::numeric_limits<double>::max(), double hi = std::numeric_limits<double>::max()) {
  if (field.empty()) throw FitError(where + ": " + column + " is empty");
  double v = 0.0;
  const std::string why = parse_real_in(field, lo, hi, &v);
  if (!why.empty()) throw FitError(where + ": " + column + " '" + field + "' is " + why);
  return v;
}

// The model's value of one measurement from the totals at its incidence.
double model_value(const FitMeasurement& m, const AddingDoublingTotals& t) {
  const int c = m.channel;
  if (m.diffuse) return m.quantity == FitQuantity::kR ? t.R_hemispherical[c] : t.T_hemispherical[c];
  switch (m.quantity) {
    case FitQuantity::kR: return t.R_specular[c] + t.R_diffuse[c];
    case FitQuantity::kRDiffuse: return t.R_diffuse[c];
    case FitQuantity::kT: return t.T_ballistic[c] + t.T_diffuse[c];
    case FitQuantity::kTDiffuse: return t.T_diffuse[c];
    case FitQuantity::kTUnscattered: return t.T_ballistic[c];
    case FitQuantity::kBin: break;  // from a table (fit_model_values)
  }
  return 0.0;
}

// Eigen-decomposition of a small symmetric matrix by cyclic Jacobi rotations (Golub and Van
// Loan, Matrix Computations, 4th ed., sec. 8.5): a = V diag(lambda) V^T; columns of v.
void symmetric_eigen(std::vector<std::vector<double>> a, std::vector<double>* lambda,
                     std::vector<std::vector<double>>* v) {
  const int n = static_cast<int>(a.size());
  v->assign(n, std::vector<double>(n, 0.0));
  for (int i = 0; i < n; ++i) (*v)[i][i] = 1.0;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0.0;
    for (int p = 0; p < n; ++p)
      for (int q = p + 1; q < n; ++q) off += a[p][q] * a[p][q];
    if (off < 1e-30) break;
    for (int p = 0; p < n; ++p)
      for (int q = p + 1; q < n; ++q) {
        if (a[p][q] == 0.0) continue;
        // The rotation that zeroes a[p][q] (Golub and Van Loan, Algorithm 8.5.1).
        const double tau = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (tau >= 0 ? 1.0 : -1.0) / (std::abs(tau) + std::sqrt(1.0 + tau * tau));
        const double c = 1.0 / std::sqrt(1.0 + t * t), s = t * c;
        for (int k = 0; k < n; ++k) {  // a <- a J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < n; ++k) {  // a <- J^T a
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < n; ++k) {
          const double vkp = (*v)[k][p], vkq = (*v)[k][q];
          (*v)[k][p] = c * vkp - s * vkq;
          (*v)[k][q] = s * vkp + c * vkq;
        }
      }
  }
  lambda->resize(n);
  for (int i = 0; i < n; ++i) (*lambda)[i] = a[i][i];
}

// What the optimiser and the Jacobian evaluate: the parameter values for unknowns x, the stack,
// the model and chi^2.
struct Problem {
  const StackTemplate* t = nullptr;
  std::vector<StackParameter> parameters;
  std::vector<Spectrum> base;  // the template's values
  std::vector<FitUnknown> unknowns;
  const std::vector<FitMeasurement>* data = nullptr;
  AddingDoublingSettings forward;
  LayerStack stack;  // reused between evaluations
  int evaluations = 0;

  std::vector<Spectrum> values(const double* x) const {
    std::vector<Spectrum> v = base;
    for (std::size_t k = 0; k < unknowns.size(); ++k) {
      const FitUnknown& u = unknowns[k];
      if (u.channel < 0) v[u.parameter] = Spectrum(x[k]);
      else v[u.parameter][u.channel] = x[k];
    }
    return v;
  }
  std::vector<double> model(const double* x) {
    const std::vector<Spectrum> v = values(x);
    apply_parameters(*t, parameters, v.data(), &stack);
    ++evaluations;
    return fit_model_values(stack, *data, forward);
  }
  // Added to the model in chi2: the correction of a coarse model towards the accurate one
  // (fit_group); empty: none.
  std::vector<double> offset;
  double chi2(const std::vector<double>& m) const {
    double s = 0.0;
    for (std::size_t i = 0; i < m.size(); ++i) {
      const double r = (m[i] + (offset.empty() ? 0.0 : offset[i]) - (*data)[i].value) / (*data)[i].sigma;
      s += r * r;
    }
    return s;
  }
};

// NLopt works on the unknowns scaled to [0, 1] by their bounds, so one step size and one
// tolerance fit all of them whatever their units.
struct Scaled {
  Problem* problem;
  std::vector<double> x;
};
double scaled_objective(unsigned n, const double* u, double* grad, void* data) {
  Scaled* s = static_cast<Scaled*>(data);
  for (unsigned k = 0; k < n; ++k) {
    const FitUnknown& q = s->problem->unknowns[k];
    s->x[k] = q.lower + u[k] * (q.upper - q.lower);
  }
  const std::vector<double> m = s->problem->model(s->x.data());
  const double c = s->problem->chi2(m);
  (void)grad;  // BOBYQA is derivative-free
  return std::isfinite(c) ? c : std::numeric_limits<double>::max();
}

}  // namespace

std::vector<FitMeasurement> parse_fit_measurements(const std::string& text, const std::string& source) {
  const std::string expected = "expected quantity,channel,theta_i_deg,value,sigma";
  const CsvHeaderSpec spec{{"quantity", "channel", "theta_i_deg", "value", "sigma"}, {}, expected, expected,
                           "empty (expected the header quantity,channel,theta_i_deg,value,sigma)"};
  std::vector<FitMeasurement> out;
  read_csv_rows(text, source, spec, [&](const std::vector<std::string>& f, const std::string& where,
                                        std::map<std::string, int>& column) {
    FitMeasurement m;
    m.where = where;
    const std::string& q = f[column["quantity"]];
    if (q == "R") m.quantity = FitQuantity::kR;
    else if (q == "R_diffuse") m.quantity = FitQuantity::kRDiffuse;
    else if (q == "T") m.quantity = FitQuantity::kT;
    else if (q == "T_diffuse") m.quantity = FitQuantity::kTDiffuse;
    else if (q == "T_unscattered") m.quantity = FitQuantity::kTUnscattered;
    else throw FitError(where + ": quantity '" + q + "' is not one of R, R_diffuse, T, T_diffuse, T_unscattered");
    const std::string& ch = f[column["channel"]];
    m.channel = ch == "r" ? 0 : ch == "g" ? 1 : ch == "b" ? 2 : -1;
    if (m.channel < 0) throw FitError(where + ": channel '" + ch + "' is not r, g or b");
    const std::string& th = f[column["theta_i_deg"]];
    if (th == "diffuse") {
      m.diffuse = true;
      if (m.quantity != FitQuantity::kR && m.quantity != FitQuantity::kT)
        throw FitError(where + ": " + q + " is defined for collimated incidence only (diffuse incidence: R or T)");
    } else {
      m.theta_i_deg = parse_number(th, where, "theta_i_deg");
      if (m.theta_i_deg < 0.0 || m.theta_i_deg >= 90.0)
        throw FitError(where + ": theta_i_deg " + th + " is not in [0, 90) (or 'diffuse')");
    }
    m.value = parse_number(f[column["value"]], where, "value", -kMaxFitValue, kMaxFitValue);
    m.sigma = parse_number(f[column["sigma"]], where, "sigma", kMinFitSigma, kMaxFitSigma);
    out.push_back(m);
  });
  if (out.empty()) throw FitError(source + ": no measurements after the header");
  return out;
}

std::vector<FitMeasurement> parse_fit_table(const std::string& text, const std::string& source, double theta_i_deg,
                                            double sigma_floor) {
  if (!(theta_i_deg >= 0.0 && theta_i_deg < 90.0))
    throw FitError(source + ": the table's incidence " + number_text(theta_i_deg) + " is not in [0, 90)");
  if (!(sigma_floor >= 0.0) || !std::isfinite(sigma_floor))
    throw FitError(source + ": the sigma floor " + number_text(sigma_floor) + " must be finite and >= 0");
  const CsvHeaderSpec spec{{"side", "channel", "theta_o_deg", "phi_o_deg", "value", "stderr"}, {"single", "multiple"},
                           "expected lamina brdf's side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple",
                           "a lamina brdf table", "empty (expected lamina brdf's table header)"};
  struct Row {
    FitMeasurement m;
    double theta_o, phi_o;
  };
  std::vector<Row> rows;
  std::vector<double> thetas, phis;  // distinct values
  read_csv_rows(text, source, spec, [&](const std::vector<std::string>& f, const std::string& where,
                                        std::map<std::string, int>& column) {
    Row r;
    r.m.where = where;
    r.m.quantity = FitQuantity::kBin;
    r.m.theta_i_deg = theta_i_deg;
    const std::string& side = f[column["side"]];
    if (side == "reflect") r.m.side = 0;
    else if (side == "transmit") r.m.side = 1;
    else throw FitError(where + ": side '" + side + "' is not reflect or transmit");
    const std::string& ch = f[column["channel"]];
    r.m.channel = ch == "r" ? 0 : ch == "g" ? 1 : ch == "b" ? 2 : -1;
    if (r.m.channel < 0) throw FitError(where + ": channel '" + ch + "' is not r, g or b");
    r.theta_o = parse_number(f[column["theta_o_deg"]], where, "theta_o_deg");
    r.phi_o = parse_number(f[column["phi_o_deg"]], where, "phi_o_deg");
    if (r.theta_o < 0.0 || r.theta_o > 90.0) throw FitError(where + ": theta_o_deg " + f[column["theta_o_deg"]] + " is not in [0, 90]");
    if (r.phi_o < 0.0 || r.phi_o >= 360.0) throw FitError(where + ": phi_o_deg " + f[column["phi_o_deg"]] + " is not in [0, 360)");
    r.m.value = parse_number(f[column["value"]], where, "value", -kMaxFitValue, kMaxFitValue);
    const double stderr_ = parse_number(f[column["stderr"]], where, "stderr", 0.0, kMaxFitSigma);
    r.m.sigma = std::hypot(stderr_, sigma_floor);
    if (!(r.m.sigma > 0.0))
      throw FitError(where + ": stderr is 0 and no sigma floor is given: the bin has no uncertainty to weigh it by");
    if (!(r.m.sigma >= kMinFitSigma && r.m.sigma <= kMaxFitSigma))
      throw FitError(where + ": the bin's sigma sqrt(stderr^2 + floor^2) = " + number_text(r.m.sigma) + " is not in [" +
                     number_text(kMinFitSigma) + ", " + number_text(kMaxFitSigma) + "]");
    // Distinct values: equal to the format's 9 digits.
    auto add_distinct = [](std::vector<double>& v, double x) {
      for (double y : v)
        if (std::abs(x - y) <= 1e-7 * std::max(1.0, std::abs(x))) return;
      v.push_back(x);
    };
    add_distinct(thetas, r.theta_o);
    add_distinct(phis, r.phi_o);
    rows.push_back(r);
  });
  if (rows.empty()) throw FitError(source + ": no bins after the header");
  const int K = static_cast<int>(thetas.size()), M = static_cast<int>(phis.size());
  std::vector<FitMeasurement> out;
  for (Row& r : rows) {
    // The bin whose centre this is (materials/brdf/brdf_table.h: cos centre (k + 1/2) / K, phi
    // centre (m + 1/2) 360 / M), checked to the format's precision.
    const int k = std::clamp(static_cast<int>(std::floor(std::cos(r.theta_o * kPi / 180.0) * K)), 0, K - 1);
    const int m = std::clamp(static_cast<int>(std::floor(r.phi_o / 360.0 * M)), 0, M - 1);
    const double theta_c = std::acos((k + 0.5) / K) * 180.0 / kPi, phi_c = (m + 0.5) * 360.0 / M;
    if (std::abs(theta_c - r.theta_o) > 1e-6 || std::abs(phi_c - r.phi_o) > 1e-6)
      throw FitError(r.m.where + ": (theta_o, phi_o) = (" + number_text(r.theta_o) + ", " + number_text(r.phi_o) +
                     ") is not a bin centre of the " + std::to_string(K) + " x " + std::to_string(M) +
                     " grid the table's distinct angles give (every ring and azimuth must appear)");
    r.m.bin_theta = k;
    r.m.bin_phi = m;
    r.m.bins_theta = K;
    r.m.bins_phi = M;
    out.push_back(r.m);
  }
  return out;
}

std::vector<FitMeasurement> load_fit_measurements(const std::string& path) {
  std::string text;
  const std::string why = read_text_file(path, &text);
  if (!why.empty()) throw FitError(path + ": cannot read the measurements: " + why);
  return parse_fit_measurements(text, path);
}

std::vector<double> fit_model_values(const LayerStack& stack, const std::vector<FitMeasurement>& data,
                                     const AddingDoublingSettings& settings) {
  // Totals: one solution per distinct collimated incidence; every solution also carries the
  // diffuse-incidence totals (materials/adding_doubling/adding_doubling.h), so diffuse data reuse the first.
  // Bins: one table solution per grid (K, M) for all of its incidences at once (each incidence
  // is one more node of the same solution).
  std::map<double, AddingDoublingTotals> by_angle;
  std::map<std::pair<int, int>, std::vector<double>> grids;  // (K, M) -> incidences
  bool totals = false;
  for (const FitMeasurement& m : data) {
    if (m.quantity == FitQuantity::kBin) {
      std::vector<double>& angles = grids[{m.bins_theta, m.bins_phi}];
      if (std::find(angles.begin(), angles.end(), m.theta_i_deg) == angles.end()) angles.push_back(m.theta_i_deg);
      continue;
    }
    totals = true;
    if (!m.diffuse && !by_angle.count(m.theta_i_deg))
      by_angle.emplace(m.theta_i_deg, adding_doubling_totals(stack, std::cos(m.theta_i_deg * kPi / 180.0), settings));
  }
  if (totals && by_angle.empty()) by_angle.emplace(0.0, adding_doubling_totals(stack, 1.0, settings));
  std::map<std::pair<int, int>, std::vector<BrdfTable>> tables;
  for (const auto& [grid, angles] : grids) {
    BrdfOptions o;
    o.bins_theta = grid.first;
    o.bins_phi = grid.second;
    AddingDoublingSettings s = settings;
    s.single_scattering_bins = false;  // the values only
    tables[grid] = brdf_tables_adding_doubling(stack, o, angles, s);
  }
  std::vector<double> out(data.size());
  for (std::size_t i = 0; i < data.size(); ++i) {
    const FitMeasurement& m = data[i];
    if (m.quantity == FitQuantity::kBin) {
      const std::pair<int, int> grid{m.bins_theta, m.bins_phi};
      const std::vector<double>& angles = grids.at(grid);
      const BrdfTable& t = tables.at(grid)[std::find(angles.begin(), angles.end(), m.theta_i_deg) - angles.begin()];
      out[i] = t.value[t.bin_index(static_cast<BrdfSide>(m.side), m.bin_theta, m.bin_phi)][m.channel];
      continue;
    }
    out[i] = model_value(m, m.diffuse ? by_angle.begin()->second : by_angle.at(m.theta_i_deg));
  }
  return out;
}

namespace {

// One independent least-squares problem: all unknowns and measurements if a scalar unknown ties
// the channels together, else those of one channel (the transport in one channel does not see
// the others, so chi^2 is a sum of independent per-channel terms and each is minimised alone,
// with a forward model that solves that channel only). Fills r at the group's indices.
// BOBYQA (M. J. D. Powell, "The BOBYQA algorithm for bound constrained optimization without
// derivatives", 2009: quadratic models from interpolation; chi^2 is smooth and nearly quadratic
// near its minimum) from *x with the initial step `step` in the unknowns scaled to [0, 1]. On the
// R, T slab (bench/bench_fit.cpp) it needed 58 solutions against 69 for L-BFGS and 102 for
// truncated Newton with difference gradients; SLSQP stopped at the start.
void minimise_chi2(Problem& pb, std::vector<double>* x, double step, const FitSettings& settings, FitResult* r) {
  const int n = static_cast<int>(pb.unknowns.size());
  std::vector<double> u(n), lo(n, 0.0), hi(n, 1.0), steps(n, step);
  for (int k = 0; k < n; ++k) {
    const FitUnknown& q = pb.unknowns[k];
    u[k] = std::clamp(((*x)[k] - q.lower) / (q.upper - q.lower), 0.0, 1.0);
  }
  nlopt_opt opt = nlopt_create(NLOPT_LN_BOBYQA, static_cast<unsigned>(n));
  Scaled scaled{&pb, std::vector<double>(n)};
  nlopt_set_lower_bounds(opt, lo.data());
  nlopt_set_upper_bounds(opt, hi.data());
  nlopt_set_initial_step(opt, steps.data());
  nlopt_set_min_objective(opt, scaled_objective, &scaled);
  nlopt_set_xtol_rel(opt, settings.relative_tolerance);
  nlopt_set_xtol_abs1(opt, settings.relative_tolerance);
  nlopt_set_ftol_abs(opt, settings.chi2_tolerance);
  nlopt_set_maxeval(opt, settings.max_evaluations);
  double best = 0.0;
  const nlopt_result status = nlopt_optimize(opt, u.data(), &best);
  nlopt_destroy(opt);
  if (status < 0 && status != NLOPT_ROUNDOFF_LIMITED)
    throw FitError("the optimiser failed (NLopt status " + std::to_string(static_cast<int>(status)) + ")");
  if (status == NLOPT_MAXEVAL_REACHED &&
      (r->warnings.empty() || r->warnings.back().rfind("the optimiser stopped after", 0) != 0))  // once per group
    r->warnings.push_back("the optimiser stopped after " + std::to_string(settings.max_evaluations) +
                          " solutions without converging: the values may not be the minimum");
  for (int k = 0; k < n; ++k) (*x)[k] = pb.unknowns[k].lower + u[k] * (pb.unknowns[k].upper - pb.unknowns[k].lower);
}

// One independent least-squares problem: all unknowns and measurements if a scalar unknown ties
// the channels together, else those of one channel (the transport in one channel does not see
// the others, so chi^2 is a sum of independent per-channel terms and each is minimised alone,
// with a forward model that solves that channel only). Fills r at the group's indices.
void fit_group(Problem& pb, const std::vector<int>& unknown_index, const std::vector<int>& data_index,
               const FitSettings& settings, FitResult* r) {
  const int n = static_cast<int>(pb.unknowns.size());
  const std::vector<FitMeasurement>& data = *pb.data;
  const int nm = static_cast<int>(data.size());
  std::vector<double> x(n), model;
  for (int k = 0; k < n; ++k) x[k] = pb.unknowns[k].start;
  bool polish = false;  // the Gauss-Newton step after the defect correction
  const int coarse_points = settings.coarse_quadrature_points;
  if (coarse_points > 0 && coarse_points < pb.forward.quadrature_points) {
    // Defect correction (the multigrid idea; for least squares, the "space mapping" of Bandler
    // et al., IEEE Trans. Microwave Theory Tech. 42 (1994) 2536): the optimiser's many solutions
    // use the coarse model m_c, cheap, and the accurate model m_N only corrects it. With the
    // offset d = m_N(x_k) - m_c(x_k) the coarse model is exact at x_k, and x_{k+1} minimises
    // chi^2 of m_c + d. At a fixed point m_c(x) + d = m_N(x): the residuals are the accurate
    // model's, and the gradient condition J_c^T W r = 0 differs from the accurate optimum's
    // J_N^T W r = 0 only by (J_c - J_N)^T W r, which the Gauss-Newton step after the Jacobian
    // (below) removes. Each iteration shrinks the distance to the fixed point by about the
    // relative difference of the two Jacobians: ~1e-2 for totals at 4 points, so two or three
    // accurate solutions suffice; for the bins of a BRDF table, whose angular detail 4 points
    // resolve poorly, only ~0.5. The iteration stops when the accurate model moved by less than
    // kSettledSigma of every measurement's sigma between two iterates: the Gauss-Newton step on
    // the accurate model then does the rest, its error being of second order in that distance
    // (with 0.01 instead, a table fit took 8 corrections and the same answer).
    Problem coarse = pb;
    coarse.forward.quadrature_points = coarse_points;
    coarse.evaluations = 0;
    coarse.offset.assign(nm, 0.0);
    minimise_chi2(coarse, &x, 0.1, settings, r);
    std::vector<double> previous;
    constexpr double kSettledSigma = 0.05;
    for (int iteration = 0;; ++iteration) {
      model = pb.model(x.data());
      const std::vector<double> mc = coarse.model(x.data());
      // How far the last correction moved the accurate model, in sigmas (before the first: how
      // far the coarse model is from it).
      double moved = 0.0;
      for (int i = 0; i < nm; ++i)
        moved = std::max(moved, std::abs(model[i] - (previous.empty() ? mc[i] : previous[i])) / data[i].sigma);
      if (!previous.empty() && moved < kSettledSigma) break;
      if (iteration >= settings.max_corrections) {
        r->warnings.push_back("the coarse model's correction did not settle in " + std::to_string(iteration) +
                              " steps (the accurate model still moved by " + number_text(moved) +
                              " sigma): the values may not be the optimum; search on the accurate model (coarse "
                              "quadrature points 0)");
        break;
      }
      for (int i = 0; i < nm; ++i) coarse.offset[i] = model[i] - mc[i];
      previous = model;
      // The step from here is of the order of the discretisation's shift: a small trust region.
      minimise_chi2(coarse, &x, 1e-3, settings, r);
    }
    r->coarse_evaluations += coarse.evaluations;
    polish = true;
    r->evaluations += coarse.evaluations;
  } else {
    minimise_chi2(pb, &x, 0.1, settings, r);
    model = pb.model(x.data());
  }
  for (int i = 0; i < nm; ++i) {
    r->model[data_index[i]] = model[i];
    r->residual[data_index[i]] = (model[i] - data[i].value) / data[i].sigma;
  }

  // The Jacobian dm_i/dx_k by central differences (one-sided within the bounds). Step: 1e-4 of
  // the value's magnitude, or 1e-7 of min(bound range, 1) for a value near 0 (not of the range
  // alone: absurdly wide bounds would make the step absurd too): the truncation error O(h^2
  // m''') is ~1e-8 relative, the solver's round-off (~1e-12) / h far below the sigmas.
  // After the defect correction the model at x is at hand, and one-sided differences from it
  // save one accurate solution per unknown: with a step of 1e-6 (not 1e-4) of the magnitude the
  // truncation error O(h m'') and the round-off (~1e-12) / h are both ~1e-6 relative, so the
  // sigmas move by ~1e-6 and the scaled curvature matrix's eigenvalues by ~1e-12, far below
  // the identifiability threshold of 1e-8.
  const bool one_sided = polish;
  std::vector<std::vector<double>> J(nm, std::vector<double>(n, 0.0));
  std::vector<bool> at_bound(n, false);
  for (int k = 0; k < n; ++k) {
    const FitUnknown& q = pb.unknowns[k];
    const double range = q.upper - q.lower;
    const double h = (one_sided ? 1e-6 : 1e-4) * std::max(std::abs(x[k]), 1e-3 * std::min(range, 1.0));
    at_bound[k] = x[k] <= q.lower + 1e-6 * range || x[k] >= q.upper - 1e-6 * range;
    std::vector<double> xp = x, xm = x;
    xp[k] = std::min(x[k] + h, q.upper);
    xm[k] = std::max(x[k] - h, q.lower);
    if (one_sided) {  // towards the interior
      if (xp[k] > x[k]) xm[k] = x[k];
      else xp[k] = x[k];
    }
    const std::vector<double> mp = xp[k] == x[k] ? model : pb.model(xp.data());
    const std::vector<double> mm = xm[k] == x[k] ? model : pb.model(xm.data());
    for (int i = 0; i < nm; ++i) J[i][k] = (mp[i] - mm[i]) / (xp[k] - xm[k]);
  }
  // alpha = J^T W J, scaled to unit diagonal: S = D^-1/2 alpha D^-1/2.
  std::vector<std::vector<double>> alpha(n, std::vector<double>(n, 0.0));
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int i = 0; i < nm; ++i) alpha[a][b] += J[i][a] * J[i][b] / (data[i].sigma * data[i].sigma);
  std::vector<bool> identified(n, true);
  std::vector<double> d(n);
  for (int k = 0; k < n; ++k) {
    d[k] = alpha[k][k];
    if (!(d[k] > 0.0)) {
      identified[k] = false;
      r->warnings.push_back(pb.unknowns[k].name + ": not identified: the measurements do not depend on it");
    }
  }
  std::vector<std::vector<double>> S(n, std::vector<double>(n, 0.0));
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      if (identified[a] && identified[b]) S[a][b] = alpha[a][b] / std::sqrt(d[a] * d[b]);
      else S[a][b] = a == b ? 1.0 : 0.0;  // kept out of the eigenproblem
  std::vector<double> lambda;
  std::vector<std::vector<double>> V;
  symmetric_eigen(S, &lambda, &V);
  std::vector<std::vector<double>> Cs(n, std::vector<double>(n, 0.0));
  for (int e = 0; e < n; ++e) {
    if (lambda[e] < kIdentifiabilityThreshold) {
      // A combination not determined: every unknown with a part in it (weight above 0.01 of the
      // unit eigenvector) has an unbounded variance, so it loses its sigma; the message names
      // them, largest weight first.
      std::vector<std::pair<double, int>> carried;
      for (int k = 0; k < n; ++k)
        if (identified[k] && std::abs(V[k][e]) > 0.01) carried.push_back({-std::abs(V[k][e]), k});
      std::sort(carried.begin(), carried.end());
      std::string names;
      for (const auto& [w, k] : carried) {
        names += (names.empty() ? "" : ", ") + pb.unknowns[k].name;
        identified[k] = false;
      }
      if (!names.empty())
        r->warnings.push_back(names + ": not identified: the measurements determine only a combination of " +
                              (names.find(',') == std::string::npos ? "it with others" : "them") + " (eigenvalue " +
                              number_text(std::max(lambda[e], 0.0)) +
                              " of the scaled curvature matrix J^T W J); add measurements that separate them "
                              "(other angles, T_unscattered) or fix one");
      continue;
    }
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) Cs[a][b] += V[a][e] * V[b][e] / lambda[e];
  }
  for (int a = 0; a < n; ++a) {
    const int ga = unknown_index[a];
    r->value[ga] = x[a];
    r->at_bound[ga] = at_bound[a];
    for (int b = 0; b < n; ++b)
      if (identified[a] && identified[b]) r->covariance[ga][unknown_index[b]] = Cs[a][b] / std::sqrt(d[a] * d[b]);
    if (identified[a]) r->sigma[ga] = std::sqrt(r->covariance[ga][ga]);
    else r->covariance[ga][ga] = std::numeric_limits<double>::infinity();
    if (at_bound[a])
      r->warnings.push_back(pb.unknowns[a].name + ": at its bound (" + number_text(x[a]) +
                            "): the optimum may lie beyond it, and its sigma assumes it does not");
  }
  // After the defect correction: one Gauss-Newton step on the accurate model, dx = C J^T W
  // (y - m) with the accurate Jacobian J and C = (J^T W J)^-1 from above (the pseudo-inverse
  // over the identified unknowns; Numerical Recipes, 3rd ed., sec. 15.5). It moves the fixed
  // point of the correction, where J_c^T W r = 0, to where J^T W r = 0, the accurate optimum
  // (to second order: the step is ~1e-2 sigma). Not at a bound, where the optimum is the
  // bound's and a free step would leave the box. The covariance stays that of the point before
  // the step, which differs by a fraction of the step's relative size.
  if (!polish) return;
  std::vector<double> gradient(n, 0.0);  // J^T W (y - m)
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < nm; ++i) gradient[k] += J[i][k] * (data[i].value - model[i]) / (data[i].sigma * data[i].sigma);
  std::vector<double> step(n, 0.0);
  double largest = 0.0;
  for (int a = 0; a < n; ++a) {
    if (at_bound[a]) return;
    if (!identified[a]) continue;
    for (int b = 0; b < n; ++b)
      if (identified[b]) step[a] += r->covariance[unknown_index[a]][unknown_index[b]] * gradient[b];
    largest = std::max(largest, std::abs(step[a]) / r->sigma[unknown_index[a]]);
  }
  if (!(largest > 1e-4)) return;  // already at the optimum to 1e-4 sigma
  for (int a = 0; a < n; ++a) x[a] = std::clamp(x[a] + step[a], pb.unknowns[a].lower, pb.unknowns[a].upper);
  const std::vector<double> polished = pb.model(x.data());
  for (int i = 0; i < nm; ++i) {
    r->model[data_index[i]] = polished[i];
    r->residual[data_index[i]] = (polished[i] - data[i].value) / data[i].sigma;
  }
  for (int a = 0; a < n; ++a) r->value[unknown_index[a]] = x[a];
}

}  // namespace

std::string rough_projection_refusal(const StackTemplate& t, const StackParameter& p) {
  if (p.kind == StackParameter::Kind::kRoughness)
    return p.path + ": a rough interface's roughness is not fitted: every evaluation would project the interface "
                    "anew, and the energy-conserving one's multiple scattering is estimated by walks at fixed seeds, "
                    "which is not smooth in alpha (docs/fitting.md)";
  const bool rough = t.stack.rough_top() || t.stack.energy_conserving_rough();
  if (rough && (p.kind == StackParameter::Kind::kIor || p.kind == StackParameter::Kind::kBelowIor))
    return p.path + ": an index is not fitted on a stack with rough interfaces: the solver's directions depend on "
                    "every index, so every evaluation would project the rough interfaces anew (docs/fitting.md)";
  return {};
}

FitResult fit_stack(const StackTemplate& t, const std::vector<FitParameterSpec>& specs,
                    const std::vector<FitMeasurement>& data, const FitSettings& settings) {
  if (specs.empty()) throw FitError("no parameter to fit");
  if (data.empty()) throw FitError("no measurements");
  std::vector<StackParameter> parameters;
  std::vector<Spectrum> base;
  std::vector<FitUnknown> unknowns;
  bool channel_measured[kChannels] = {false, false, false};
  for (const FitMeasurement& m : data) channel_measured[m.channel] = true;
  bool joint = false;  // a scalar unknown ties the channels together
  for (std::size_t k = 0; k < specs.size(); ++k) {
    const FitParameterSpec& s = specs[k];
    StackParameter p;
    try {
      p = parse_stack_parameter(t, s.path);
    } catch (const StackParameterError& e) {
      throw FitError(e.what());
    }
    const std::string fixed = rough_projection_refusal(t, p);
    if (!fixed.empty()) throw FitError(fixed);
    if (!std::isfinite(s.lower) || !std::isfinite(s.upper))
      throw FitError(s.path + ": bounds must be finite, got " + number_text(s.lower) + ":" + number_text(s.upper));
    if (!(s.lower < s.upper))
      throw FitError(s.path + ": the lower bound " + number_text(s.lower) + " is not below the upper bound " + number_text(s.upper));
    if (s.lower < p.min_value() || s.upper > p.max_value())
      throw FitError(s.path + ": bounds " + number_text(s.lower) + ":" + number_text(s.upper) +
                     " leave the parameter's range [" + number_text(p.min_value()) + ", " + number_text(p.max_value()) + "]");
    parameters.push_back(p);
    const Spectrum v0 = p.template_value(t);
    base.push_back(v0);
    auto add = [&](int channel) {
      FitUnknown u;
      u.parameter = static_cast<int>(k);
      u.channel = channel;
      u.name = channel < 0 ? s.path : s.path + "[" + kChannelNames[channel] + "]";
      u.lower = s.lower;
      u.upper = s.upper;
      u.start = std::clamp(v0[channel < 0 ? 0 : channel], s.lower, s.upper);
      unknowns.push_back(u);
    };
    if (!p.spectral()) {
      add(-1);
      joint = true;
    } else {
      for (int c = 0; c < kChannels; ++c)
        if (channel_measured[c]) add(c);
    }
  }
  try {
    check_parameter_set(parameters);
  } catch (const StackParameterError& e) {
    throw FitError(e.what());
  }
  const int n = static_cast<int>(unknowns.size());
  FitResult r;
  r.unknowns = unknowns;
  r.value.assign(n, 0.0);
  r.sigma.assign(n, std::numeric_limits<double>::infinity());
  r.at_bound.assign(n, false);
  r.covariance.assign(n, std::vector<double>(n, 0.0));
  r.model.assign(data.size(), 0.0);
  r.residual.assign(data.size(), 0.0);
  struct Group {
    int channel;                 // -1: all (a scalar unknown ties the channels)
    std::vector<int> ui, di;     // its unknowns and measurements
    FitResult partial;           // fit_group's output, at the global indices
    int evaluations = 0;
  };
  std::vector<Group> groups;
  for (int group = joint ? -1 : 0; group < (joint ? 0 : kChannels); ++group) {
    Group g{group, {}, {}, {}, 0};
    for (int k = 0; k < n; ++k)
      if (group < 0 || unknowns[k].channel == group) g.ui.push_back(k);
    for (std::size_t i = 0; i < data.size(); ++i)
      if (group < 0 || data[i].channel == group) g.di.push_back(static_cast<int>(i));
    if (g.di.empty()) continue;
    if (g.ui.empty()) {  // measurements of a channel with no unknown: the model's values, unfitted
      const std::vector<double> m = fit_model_values(t.stack, data, settings.forward);
      for (int i : g.di) {
        r.model[i] = m[i];
        r.residual[i] = (m[i] - data[i].value) / data[i].sigma;
      }
      continue;
    }
    groups.push_back(std::move(g));
  }
  // Rough interfaces: their projection onto the solver's basis depends only on alpha, the indices
  // and the quadrature, none of which the fit varies, so interface_fourier.h's cache makes it
  // once for every evaluation. Made here before the groups start, so that parallel groups do not
  // each make it at once (the coarse search's and the accurate model's quadrature).
  if (groups.size() > 1 && (t.stack.rough_top() || t.stack.energy_conserving_rough())) {
    AddingDoublingSettings warm = settings.forward;
    warm.only_channel = groups.front().channel < 0 ? 0 : groups.front().channel;
    const int coarse = settings.coarse_quadrature_points;
    if (coarse > 0 && coarse < warm.quadrature_points) {
      AddingDoublingSettings c = warm;
      c.quadrature_points = coarse;
      fit_model_values(t.stack, data, c);
    }
    fit_model_values(t.stack, data, warm);
  }
  // The channels' problems are independent: solved in parallel, each into its own partial
  // result, merged in channel order (the same result and warnings for any number of threads).
  tbb::parallel_for(std::size_t(0), groups.size(), [&](std::size_t gi) {
    Group& g = groups[gi];
    std::vector<FitMeasurement> group_data;
    for (int i : g.di) group_data.push_back(data[i]);
    Problem pb;
    pb.t = &t;
    pb.parameters = parameters;
    pb.base = base;
    for (int k : g.ui) pb.unknowns.push_back(unknowns[k]);
    pb.data = &group_data;
    pb.forward = settings.forward;
    pb.forward.only_channel = g.channel;
    g.partial = r;
    g.partial.warnings.clear();
    g.partial.evaluations = g.partial.coarse_evaluations = 0;
    fit_group(pb, g.ui, g.di, settings, &g.partial);
    g.evaluations = pb.evaluations;
  });
  for (const Group& g : groups) {
    for (int i : g.di) {
      r.model[i] = g.partial.model[i];
      r.residual[i] = g.partial.residual[i];
    }
    for (int a : g.ui) {
      r.value[a] = g.partial.value[a];
      r.sigma[a] = g.partial.sigma[a];
      r.at_bound[a] = g.partial.at_bound[a];
      for (int b : g.ui) r.covariance[a][b] = g.partial.covariance[a][b];
    }
    for (const std::string& w : g.partial.warnings)  // the same line from two channels once
      if (std::find(r.warnings.begin(), r.warnings.end(), w) == r.warnings.end()) r.warnings.push_back(w);
    r.evaluations += g.partial.evaluations + g.evaluations;
    r.coarse_evaluations += g.partial.coarse_evaluations;
  }
  for (std::size_t i = 0; i < data.size(); ++i) r.chi2 += r.residual[i] * r.residual[i];
  r.dof = static_cast<int>(data.size()) - n;
  r.parameter_values = base;
  for (int k = 0; k < n; ++k) {
    const FitUnknown& u = unknowns[k];
    if (u.channel < 0) r.parameter_values[u.parameter] = Spectrum(r.value[k]);
    else r.parameter_values[u.parameter][u.channel] = r.value[k];
  }
  apply_parameters(t, parameters, r.parameter_values.data(), &r.stack);
  if (settings.check_discretisation) {
    AddingDoublingSettings fine = settings.forward;
    fine.only_channel = -1;
    for (int c = 0; c < kChannels; ++c)  // one channel measured: solve only it
      if (std::all_of(data.begin(), data.end(), [c](const FitMeasurement& m) { return m.channel == c; })) fine.only_channel = c;
    // The largest move of a measurement's model value, in its sigmas, from r.model.
    std::size_t at = 0;
    auto worst_move = [&](const std::vector<double>& m2) {
      double worst = 0.0;
      for (std::size_t i = 0; i < data.size(); ++i) {
        const double z = std::abs(m2[i] - r.model[i]) / data[i].sigma;
        if (z > worst) worst = z, at = i;
      }
      return worst;
    };
    // A cheap screen first: half the points (a solution at 2N costs ~6x one at N, and 50x one
    // at N/2). The error falls by about 10x per doubling of the points (docs/validation.md, the convergence
    // table: 4e-5, 4.5e-6, 2.3e-7 at 8, 16, 32), so |m_N - m_N/2|, about the error of m_N/2, is
    // several times |m_N - m_2N|, about the error of m_N: if the former is within 0.2 sigma the
    // latter is too and 2N is not solved.
    AddingDoublingSettings half = fine;
    half.quadrature_points = std::max(2, settings.forward.quadrature_points / 2);
    bool screened = false;
    if (half.quadrature_points < settings.forward.quadrature_points) {
      ++r.evaluations;
      screened = worst_move(fit_model_values(r.stack, data, half)) <= 0.2;
    }
    fine.quadrature_points *= 2;
    double worst = 0.0;
    if (!screened) {
      ++r.evaluations;
      worst = worst_move(fit_model_values(r.stack, data, fine));
    }
    if (worst > 0.2)
      r.warnings.push_back(data[at].where + ": the forward model at " + std::to_string(settings.forward.quadrature_points) +
                           " quadrature points differs from " + std::to_string(fine.quadrature_points) + " by " +
                           number_text(worst) + " sigma; raise the quadrature points");
  }
  return r;
}

void write_fitted_values(nlohmann::json& j, const StackTemplate& t, const std::vector<FitParameterSpec>& specs,
                         const FitResult& result) {
  for (std::size_t k = 0; k < specs.size(); ++k) {
    const StackParameter p = parse_stack_parameter(t, specs[k].path);
    const Spectrum& v = result.parameter_values[k];
    nlohmann::json* node = find_stack_value(j, split_stack_path(specs[k].path), specs[k].path);
    if (p.spectral()) *node = nlohmann::json::array({v[0], v[1], v[2]});
    else *node = v[0];
    if (p.kind != StackParameter::Kind::kFraction) continue;
    // The other fractions of the layer, rescaled as apply_parameters does: by (1 - f) / rest,
    // rest their total in the template, or an equal share of 1 - f if rest is 0.
    const LayerDesc& d = t.layers[p.layer];
    const int m = static_cast<int>(d.components.size());
    double rest = 0.0;
    for (int c = 0; c < m; ++c)
      if (c != p.component) rest += d.components[c].fraction;
    nlohmann::json& components = j["layers"][p.layer]["components"];
    for (int c = 0; c < m; ++c)
      if (c != p.component)
        components[c]["fraction"] = rest > 0.0 ? d.components[c].fraction * (1.0 - v[0]) / rest : (1.0 - v[0]) / (m - 1);
  }
}

}  // namespace lamina
