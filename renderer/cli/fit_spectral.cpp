// lamina fit --spectrum (renderer/cli/fit_spectral.h). The spectrum CSV: lines starting with '#'
// are comments, then a header "nm,NAME,..." and one row per wavelength (nm increasing); the
// column fitted is --spectrum-column (default the first after nm). Output, one JSON object:
// "parameters" {PATH: value}, "rmse", "evaluations", "coarse_evaluations", "theta_i_deg",
// "column", "wavelength_nm", "measured", "modelled", and when the wavelengths cover 400-700 nm
// "measured_rec709" and "modelled_rec709" (the colours under D65, materials/spectral/colour.h).
#include "renderer/cli/fit_spectral.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "materials/brdf/brdf_table.h"
#include "materials/fit/spectral_fit.h"
#include "materials/stack/stack_file.h"
#include "renderer/cli/options.h"
#include "renderer/cli/outputs.h"
#include "renderer/cli/spectral_report.h"

namespace lamina::cli {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string f; std::getline(ss, f, ',');) out.push_back(f);
  return out;
}

// Reads the wavelengths and one column; throws FitError("FILE: line N: reason").
void read_spectrum(const std::string& path, const std::string& wanted, std::string* column, std::vector<double>* nm,
                   std::vector<double>* values) {
  std::ifstream in(path);
  if (!in) throw FitError(path + ": cannot open");
  std::string line;
  int number = 0, index = -1;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> f = split(line);
    const std::string where = path + ": line " + std::to_string(number) + ": ";
    if (index < 0) {
      if (f.size() < 2 || f[0] != "nm") throw FitError(where + "expected a header nm,NAME,...");
      for (std::size_t i = 1; i < f.size(); ++i)
        if (wanted.empty() ? i == 1 : f[i] == wanted) index = static_cast<int>(i);
      if (index < 0) throw FitError(where + "no column '" + wanted + "'");
      *column = f[index];
      continue;
    }
    double w = 0.0, v = 0.0;
    if (static_cast<int>(f.size()) <= index || !parse_real(f[0], &w).empty() || !parse_real(f[index], &v).empty())
      throw FitError(where + "expected numbers in nm and column " + *column);
    if (!nm->empty() && !(w > nm->back())) throw FitError(where + "wavelengths must increase");
    if (w < 250.0 || w > 2500.0) throw FitError(where + "wavelength outside 250-2500 nm");
    nm->push_back(w);
    values->push_back(v);
  }
  if (nm->empty()) throw FitError(path + ": no spectrum");
}


}  // namespace

int run_fit_spectral(const SpectralFitRequest& r) {
  try {
    const SpectralStack stack = load_spectral_stack(r.stack_path);
    std::string column;
    std::vector<double> nm, measured;
    read_spectrum(r.spectrum_path, r.column, &column, &nm, &measured);
    check_output_paths({{"--summary", r.summary_path}});
    AddingDoublingSettings settings;
    settings.quadrature_points = r.quadrature_points;
    const double cos_theta_i = incident_direction(r.theta_i_deg, 0.0).z;
    const SpectralFitResult fit =
        fit_spectrum(stack, r.parameters, nm, measured, cos_theta_i, settings, r.coarse_quadrature_points);
    nlohmann::ordered_json j, params;
    for (std::size_t k = 0; k < r.parameters.size(); ++k) params[r.parameters[k].path] = fit.values[k];
    j["parameters"] = params;
    j["rmse"] = fit.rmse;
    j["evaluations"] = fit.evaluations;
    j["coarse_evaluations"] = fit.coarse_evaluations;
    j["theta_i_deg"] = r.theta_i_deg;
    j["column"] = column;
    j["wavelength_nm"] = fit.nm;
    j["measured"] = fit.measured;
    j["modelled"] = fit.modelled;
    if (nm.front() <= 400.0 && nm.back() >= 700.0) {
      j["measured_rec709"] = rec709_json(nm, fit.measured);
      j["modelled_rec709"] = rec709_json(nm, fit.modelled);
    }
    const std::string json = j.dump(2) + "\n";
    write_report(r.summary_path, json);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina fit: %s\n", one_line(e.what()).c_str());
    return 1;
  }
}

}  // namespace lamina::cli
