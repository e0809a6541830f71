// lamina brdf --wavelengths (renderer/cli/brdf_spectral.h). Output, one JSON object:
//   "method", "theta_i_deg", "phi_i_deg", "quadrature_points", "wavelength_nm": [...], and for
//   each of R_specular, R_diffuse, T_ballistic, T_diffuse, absorbed, R_hemispherical,
//   T_hemispherical, absorbed_hemispherical an array over the wavelengths, with
//   "discretisation_error": {the same keys: arrays}; when the wavelengths cover 400-700 nm also
//   "R_rec709" and "T_rec709", the colour of the total reflectance (specular + diffuse) and
//   transmittance lit by D65 (materials/spectral/colour.h; held at the ends of the grid).
#include "renderer/cli/brdf_spectral.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "materials/adding_doubling/spectral_totals.h"
#include "materials/brdf/brdf_table.h"
#include "materials/stack/stack_file.h"
#include "renderer/cli/options.h"
#include "renderer/cli/outputs.h"
#include "renderer/cli/spectral_report.h"

namespace lamina::cli {
namespace {

constexpr double kMinNm = 250.0, kMaxNm = 2500.0;
constexpr int kMaxWavelengths = 10000;

WavelengthGrid parse_grid(const std::string& text) {
  double v[3];
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t end = i < 2 ? text.find(':', start) : text.size();
    std::size_t used = 0;
    const std::string part = end == std::string::npos ? "" : text.substr(start, end - start);
    try {
      v[i] = std::stod(part, &used);
    } catch (const std::exception&) {
      used = std::string::npos;
    }
    if (part.empty() || used != part.size() || !std::isfinite(v[i]))
      throw UsageError("--wavelengths: expected FIRST:LAST:STEP in nm (e.g. 400:1000:10), got '" + text + "'");
    start = end + 1;
  }
  if (!(v[0] >= kMinNm && v[1] <= kMaxNm && v[0] <= v[1] && v[2] > 0.0))
    throw UsageError("--wavelengths: needs 250 <= FIRST <= LAST <= 2500 and STEP > 0, got '" + text + "'");
  if ((v[1] - v[0]) / v[2] >= kMaxWavelengths)
    throw UsageError("--wavelengths: at most " + std::to_string(kMaxWavelengths) + " wavelengths");
  return WavelengthGrid::from_to(v[0], v[1], v[2]);
}


std::string spectral_json(const SpectralBrdfRequest& r, const SpectralTotals& s) {
  nlohmann::ordered_json j;
  j["method"] = "adding-doubling";
  j["theta_i_deg"] = r.theta_i_deg;
  j["phi_i_deg"] = r.phi_i_deg;
  j["quadrature_points"] = r.quadrature_points;
  j["wavelength_nm"] = s.nm;
  using Field = Spectrum AddingDoublingTotals::*;
  const std::pair<const char*, Field> keys[] = {
      {"R_specular", &AddingDoublingTotals::R_specular},       {"R_diffuse", &AddingDoublingTotals::R_diffuse},
      {"T_ballistic", &AddingDoublingTotals::T_ballistic},     {"T_diffuse", &AddingDoublingTotals::T_diffuse},
      {"absorbed", &AddingDoublingTotals::absorbed},           {"R_hemispherical", &AddingDoublingTotals::R_hemispherical},
      {"T_hemispherical", &AddingDoublingTotals::T_hemispherical},
      {"absorbed_hemispherical", &AddingDoublingTotals::absorbed_hemispherical}};
  auto column = [&](bool error, Field f) {
    std::vector<double> v;
    for (const AddingDoublingEstimate& e : s.estimates) v.push_back(((error ? e.error : e.totals).*f)[0]);
    return v;
  };
  nlohmann::ordered_json err;
  for (const auto& [key, field] : keys) {
    j[key] = column(false, field);
    err[key] = column(true, field);
  }
  j["discretisation_error"] = err;
  if (s.nm.front() <= 400.0 && s.nm.back() >= 700.0) {
    std::vector<double> reflected = column(false, &AddingDoublingTotals::R_specular);
    const std::vector<double> diffuse = column(false, &AddingDoublingTotals::R_diffuse);
    std::vector<double> transmitted = column(false, &AddingDoublingTotals::T_ballistic);
    const std::vector<double> t_diffuse = column(false, &AddingDoublingTotals::T_diffuse);
    for (std::size_t i = 0; i < reflected.size(); ++i) {
      reflected[i] += diffuse[i];
      transmitted[i] += t_diffuse[i];
    }
    j["R_rec709"] = rec709_json(s.nm, reflected);
    j["T_rec709"] = rec709_json(s.nm, transmitted);
  }
  return j.dump(2) + "\n";
}

}  // namespace

void check_wavelengths(const std::string& text) { parse_grid(text); }

int run_brdf_spectral(const SpectralBrdfRequest& r) {
  try {
    const SpectralStack stack = load_spectral_stack(r.stack_path);
    check_output_paths({{"--summary", r.summary_path}});
    AddingDoublingSettings settings;
    settings.quadrature_points = r.quadrature_points;
    const double cos_theta_i = incident_direction(r.theta_i_deg, r.phi_i_deg).z;  // as lamina brdf
    const std::string json = spectral_json(r, adding_doubling_spectrum(stack, parse_grid(r.wavelengths), cos_theta_i, settings));
    write_report(r.summary_path, json);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina brdf: %s\n", one_line(e.what()).c_str());
    return 1;
  }
}

}  // namespace lamina::cli
