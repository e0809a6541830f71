// lamina fit: the parameters of a material file from measured totals and/or BRDF/BTDF tables in
// lamina brdf's CSV format (docs/contracts.md,
// "lamina fit"). Parses, calls materials/fit/stack_fit, prints; the physics and the statistics live
// in materials/.
//
// Outputs:
//   --out FITTED.json    the material file with the fitted values at their paths (same format)
//   --summary FIT.json   the unknowns (value, sigma, bounds, at_bound), chi2, dof, the
//                        measurements with the model's values and residuals, the warnings;
//                        printed to stdout if omitted
// Identifiability and bound warnings also go to stderr, one line each ("lamina fit: warning: ").
//
// With --albedo-texture instead of measurements: parameter maps from a colour texture through the
// albedo lookup (renderer/layered/albedo_maps.h), written all or none into --out-dir.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "materials/stack/stack_file.h"
#include "materials/stack/text_file.h"
#include "materials/fit/stack_fit.h"
#include "renderer/cli/fit_spectral.h"
#include "renderer/cli/commands.h"
#include "renderer/cli/options.h"
#include "renderer/cli/outputs.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/albedo_maps.h"
#include "renderer/layered/spectral_albedo_maps.h"
#include "renderer/util/atomic_file.h"
#include "renderer/util/progress.h"

namespace {

namespace cli = lamina::cli;

// "PATH=LO:HI" -> spec; the path itself is checked by the resolver (materials/stack/stack_parameters).
lamina::FitParameterSpec parse_param(const std::string& text) {
  const std::size_t eq = text.rfind('=');
  const std::size_t colon = eq == std::string::npos ? std::string::npos : text.find(':', eq);
  if (eq == std::string::npos || colon == std::string::npos || eq == 0)
    throw cli::UsageError("--param " + cli::in_quotes(text) + ": expected PATH=LO:HI, e.g. layers[0].sigma_s=0:100");
  lamina::FitParameterSpec s;
  s.path = text.substr(0, eq);
  const std::string lo = text.substr(eq + 1, colon - eq - 1), hi = text.substr(colon + 1);
  std::string why = cli::parse_real(lo, &s.lower);
  if (why.empty()) why = cli::parse_real(hi, &s.upper);
  if (!why.empty()) throw cli::UsageError("--param " + cli::in_quotes(text) + ": " + why);
  return s;
}

const char* quantity_name(lamina::FitQuantity q) {
  switch (q) {
    case lamina::FitQuantity::kR: return "R";
    case lamina::FitQuantity::kRDiffuse: return "R_diffuse";
    case lamina::FitQuantity::kT: return "T";
    case lamina::FitQuantity::kTDiffuse: return "T_diffuse";
    case lamina::FitQuantity::kTUnscattered: return "T_unscattered";
    case lamina::FitQuantity::kBin: return "bin";
  }
  return "?";
}

nlohmann::ordered_json number_or_null(double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(); }

std::string summary_json(const lamina::FitResult& r, const std::vector<lamina::FitMeasurement>& data, int quadrature_points,
                         const std::string& output) {
  static const char* kChannels[] = {"r", "g", "b"};
  nlohmann::ordered_json j;
  j["method"] = "adding-doubling";
  j["quadrature_points"] = quadrature_points;
  j["chi2"] = r.chi2;
  j["dof"] = r.dof;
  j["evaluations"] = r.evaluations;
  j["coarse_evaluations"] = r.coarse_evaluations;
  nlohmann::ordered_json ps = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < r.unknowns.size(); ++k) {
    const lamina::FitUnknown& u = r.unknowns[k];
    nlohmann::ordered_json p;
    p["name"] = u.name;
    p["value"] = r.value[k];
    p["sigma"] = number_or_null(r.sigma[k]);  // null: not identified
    p["lower"] = u.lower;
    p["upper"] = u.upper;
    p["start"] = u.start;
    p["at_bound"] = static_cast<bool>(r.at_bound[k]);
    ps.push_back(p);
  }
  j["parameters"] = ps;
  nlohmann::ordered_json ms = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < data.size(); ++i) {
    const lamina::FitMeasurement& m = data[i];
    nlohmann::ordered_json e;
    e["quantity"] = quantity_name(m.quantity);
    e["channel"] = kChannels[m.channel];
    if (m.diffuse) e["theta_i_deg"] = "diffuse";
    else e["theta_i_deg"] = m.theta_i_deg;
    if (m.quantity == lamina::FitQuantity::kBin) {  // the bin's centre, as the table's CSV gives it
      e["side"] = m.side == 0 ? "reflect" : "transmit";
      e["theta_o_deg"] = std::acos((m.bin_theta + 0.5) / m.bins_theta) * 180.0 / 3.14159265358979323846;
      e["phi_o_deg"] = (m.bin_phi + 0.5) * 360.0 / m.bins_phi;
    }
    e["value"] = m.value;
    e["sigma"] = m.sigma;
    e["model"] = r.model[i];
    e["residual"] = r.residual[i];
    ms.push_back(e);
  }
  j["measurements"] = ms;
  j["warnings"] = r.warnings;
  cli::check_finite_numbers(j, output);  // a non-finite chi2 or residual is a failure, not a null
  return j.dump(2) + "\n";
}

// The options of the albedo-texture mode, as parsed.
struct AlbedoOptions {
  std::string texture, decoding = "auto", out_dir, material;
  std::string stack;
  lamina::AlbedoMapsSettings settings;
  int threads = 0;
};

// The files the mode writes into --out-dir, the report last.
struct AlbedoOutputs {
  std::string maps[2], materials_map, fitted_albedo, report;
};

AlbedoOutputs albedo_outputs(const AlbedoOptions& o) {
  namespace fs = std::filesystem;
  auto in_dir = [&](const std::string& name) { return (fs::path(o.out_dir) / name).string(); };
  AlbedoOutputs out;
  for (int a = 0; a < 2; ++a) out.maps[a] = in_dir(lamina::parameter_map_file_name(o.settings.axes[a].path));
  out.materials_map = in_dir("materials.json");
  out.fitted_albedo = in_dir("fitted_albedo.png");
  out.report = in_dir("albedo_fit.json");
  return out;
}

// Usage and output-path errors (exit 2), before any file is read.
AlbedoOutputs check_albedo_usage(const AlbedoOptions& o) {
  namespace fs = std::filesystem;
  if (o.settings.axes.size() != 2)
    throw cli::UsageError("--albedo-texture: the lookup is over exactly two parameters: give two --param (got " +
                          std::to_string(o.settings.axes.size()) + ")");
  if (o.out_dir.empty()) throw cli::UsageError("--albedo-texture: give --out-dir DIR for the maps");
  std::error_code ec;
  if (!fs::is_directory(o.out_dir, ec))
    throw cli::UsageError("--out-dir '" + o.out_dir + "': " + (fs::exists(o.out_dir, ec) ? "not a directory" : "does not exist"));
  const AlbedoOutputs out = albedo_outputs(o);
  try {
    const std::vector<cli::OutputPath> outputs = {{"--out-dir", out.maps[0]},
                                                  {"--out-dir", out.maps[1]},
                                                  {"--out-dir", out.materials_map},
                                                  {"--out-dir", out.fitted_albedo},
                                                  {"--out-dir", out.report}};
    cli::check_output_paths(outputs);
    cli::check_outputs_not_inputs(outputs, {{"the material file", o.stack}, {"--albedo-texture", o.texture}});
  } catch (const cli::OutputPathError& e) {
    throw cli::UsageError(e.what());
  }
  return out;
}

int run_albedo_fit(const AlbedoOptions& o, const AlbedoOutputs& out) {
  namespace fs = std::filesystem;
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  std::optional<tbb::global_control> threads;
  if (o.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(o.threads));
  try {
    // Chromophore axes (melanin and blood maps): the spectral variant (docs/fitting.md).
    const bool spectral = lamina::chromophore_axes(o.settings.axes);
    std::optional<lamina::ChromophoreMaterial> chromophores;
    if (spectral) chromophores = lamina::load_chromophore_material(o.stack);
    const lamina::StackTemplate t = spectral ? chromophores->stack : lamina::load_stack_template(o.stack);
    try {  // the axes before the texture: a bad --param is found before a large file is read
      if (spectral) lamina::check_spectral_albedo_axes(*chromophores, o.settings.axes);
      else lamina::check_albedo_axes(t, o.settings.axes);
    } catch (const lamina::FitError& e) {
      throw lamina::FitError(o.stack + ": " + e.what());
    }
    const lamina::StoredEncoding encoding = o.decoding == "srgb"     ? lamina::StoredEncoding::kSrgb
                                            : o.decoding == "linear" ? lamina::StoredEncoding::kLinear
                                                                     : lamina::StoredEncoding::kAsFile;
    bool decoded_srgb = false;
    const lamina::Image texture = lamina::read_image(o.texture, encoding, &decoded_srgb);
    lamina::check_albedo_texture(texture, o.texture);
    std::optional<lamina::Progress> progress;
    lamina::AlbedoMapsResult r;
    lamina::SpectralAlbedoMapsResult spectral_result;
    try {
      const auto on_built = [&] { progress.emplace("fit", static_cast<std::uint64_t>(texture.width) * texture.height); };
      const auto on_progress = [&](std::size_t n) { progress->advance(n); };
      if (spectral) spectral_result = lamina::fit_spectral_albedo_maps(*chromophores, texture, o.settings, on_built, on_progress);
      else r = lamina::fit_albedo_maps(t, texture, o.settings, on_built, on_progress);
      if (spectral) r = spectral_result.maps;
    } catch (const lamina::FitError& e) {  // an axis's problem: name the file it is in
      throw lamina::FitError(o.stack + ": " + e.what());
    }
    if (progress) progress->finish();
    const std::string material = !o.material.empty()       ? o.material
                                 : !t.stack.name.empty()    ? t.stack.name
                                                            : fs::path(o.stack).stem().string();
    const std::string stack_reference = fs::weakly_canonical(fs::absolute(o.stack)).string();
    lamina::AlbedoMapsInputs inputs;
    inputs.texture = o.texture;
    inputs.texture_decoding = decoded_srgb ? "srgb" : "linear";
    inputs.stack = o.stack;
    inputs.material = material;
    inputs.materials_map = fs::path(out.materials_map).filename().string();
    inputs.fitted_albedo = fs::path(out.fitted_albedo).filename().string();
    inputs.threads = o.threads;
    inputs.total_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    const std::string map_json = lamina::albedo_materials_map_json(material, stack_reference, o.settings);
    const std::string report = spectral ? lamina::spectral_albedo_maps_report_json(spectral_result, o.settings, inputs)
                                        : lamina::albedo_maps_report_json(r, o.settings, inputs);
    cli::StagedOutputs outputs;  // every file or none
    for (int a = 0; a < 2; ++a) {
      const std::vector<float> values = lamina::parameter_map_values(r, o.settings, a);
      outputs.write(out.maps[a], [&](const std::string& tmp) { lamina::write_data_png16(tmp, r.width, r.height, values); });
    }
    outputs.write(out.materials_map, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, map_json); });
    const lamina::Image fitted = lamina::fitted_albedo_image(r);
    outputs.write(out.fitted_albedo, [&](const std::string& tmp) { lamina::write_png(tmp, fitted); });
    outputs.write(out.report, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, report); });
    outputs.commit();
    const std::size_t texels = r.match.delta_e.size();
    char clamped_text[160] = "";
    if (spectral)  // the spectral variant: the texels out of the model's gamut, and its lookup
      std::snprintf(clamped_text, sizeof clamped_text, "%zu texels (%.1f%%) clamped to a bound (out of the model's gamut); spectral ",
                    spectral_result.clamped, texels ? 100.0 * spectral_result.clamped / texels : 0.0);
    const std::string clamped = clamped_text;
    std::printf(
        "lamina fit: %d x %d texels (%s, %s albedo) -> %s: Delta E76 mean %.2f, median %.2f, 95th percentile %.2f, max %.2f; "
        "%zu texels (%.1f%%) not reachable (Delta E > %g); %slookup %d x %d in %.1f s, matching %.1f s\n",
        r.width, r.height, decoded_srgb ? "sRGB decoded" : "linear",
        o.settings.albedo == lamina::AlbedoKind::kDiffuse ? "diffuse" : "total", o.out_dir.c_str(), r.delta_e.mean, r.delta_e.median,
        r.delta_e.p95, r.delta_e.max, r.delta_e.above, texels ? 100.0 * r.delta_e.above / texels : 0.0,
        o.settings.unreachable_delta_e, clamped.c_str(), o.settings.nodes, o.settings.nodes, r.lookup_seconds, r.matching_seconds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina fit: %s\n", cli::one_line(e.what()).c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int run_fit(int argc, char** argv) {
  CLI::App app{
      "Fit parameters of a material file to measured totals (R, T, unscattered T; per channel; per\n"
      "incidence angle or diffuse) by weighted least squares on the adding-doubling solution.\n"
      "A colour parameter is fitted per channel (PATH[r], PATH[g], PATH[b]) from that channel's\n"
      "measurements; sigmas come from (J^T W J)^-1.\n"
      "With --albedo-texture: two parameter maps from a colour texture through a lookup table of\n"
      "the stack's diffuse albedo over two parameters (nearest in CIE L*a*b*).",
      "lamina fit"};
  std::string stack_path, data_path, out_path, summary_path;
  std::vector<std::string> params, tables;
  double table_sigma = 0.0;
  int quadrature_points = lamina::FitSettings{}.forward.quadrature_points;
  int coarse_points = lamina::FitSettings{}.coarse_quadrature_points;
  app.add_option("STACK.json", stack_path, "material file (JSON, docs/contracts.md): the start and the fixed values")->required();
  app.add_option("--data", data_path, "measurements CSV: quantity,channel,theta_i_deg,value,sigma");
  app.add_option("--table", tables,
                 "DEG:TABLE.csv, a measured BRDF/BTDF table in lamina brdf's CSV format for light at DEG degrees; repeat "
                 "(with or instead of --data)");
  app.add_option("--table-sigma", table_sigma,
                 "added in quadrature to each table bin's stderr (1/sr; needed where the stderr is 0)")
      ->check(cli::real(0.0, lamina::kMaxFitSigma));
  app.add_option("--param", params, "PATH=LO:HI, a parameter to fit (a texture-binding path) and its bounds; repeat")
      ->required();
  app.add_option("--quadrature-points", quadrature_points, "adding-doubling Gauss nodes per cosine segment (default 16, 8 with --albedo-texture, 4 with its chromophore parameters; 8 is ~5x faster); the fit warns if twice as many move a value by > 0.2 sigma")
      ->check(cli::integer(4, 64));
  app.add_option("--coarse-quadrature-points", coarse_points,
                 "the optimiser searches on this coarser model, corrected by a few solutions at --quadrature-points "
                 "(default 4; 0: search on --quadrature-points itself, ~5x slower, same result to ~1e-2 sigma)")
      ->check(cli::integer(0, 64));
  app.add_option("--out", out_path, "write the fitted material file here");
  app.add_option("--summary", summary_path, "write the fit's report as JSON here (default: stdout)");
  AlbedoOptions albedo;
  app.add_option("--albedo-texture", albedo.texture,
                 "instead of measurements: a colour texture (PNG, JPEG, EXR, ...) to turn into maps of the two --param; "
                 "two chromophore --param (layers[i].chromophores.KEY) fit spectrally: the colour of the albedo spectrum "
                 "under D65");
  app.add_option("--texture-decoding", albedo.decoding,
                 "albedo-texture: auto (as the file says: 8/16-bit files are sRGB unless tagged linear, float files "
                 "linear), srgb or linear")
      ->check(CLI::IsMember({"auto", "srgb", "linear"}));
  app.add_option("--out-dir", albedo.out_dir, "albedo-texture: an existing directory for the maps, materials.json, "
                                              "fitted_albedo.png and albedo_fit.json");
  app.add_option("--material", albedo.material,
                 "albedo-texture: the material name in materials.json (default: the stack's name, else its file name)");
  std::string albedo_kind = "diffuse";
  app.add_option("--albedo", albedo_kind,
                 "albedo-texture: what the texture is: diffuse (the light scattered in the stack, R_h - R_hs: a "
                 "cross-polarised albedo, the renderer's Lambert albedo; default) or total (R_hemispherical, with the "
                 "specular reflection)")
      ->check(CLI::IsMember({"diffuse", "total"}));
  app.add_option("--lookup-nodes", albedo.settings.nodes, "albedo-texture: lookup nodes per parameter (default 33)")
      ->check(cli::integer(2, 1024));
  app.add_option("--unreachable-delta-e", albedo.settings.unreachable_delta_e,
                 "albedo-texture: a texel matched farther than this (CIE76) counts as not reachable (default 2.3)")
      ->check(cli::positive());
  app.add_option("--threads", albedo.threads, "albedo-texture: threads (0: all cores); the maps do not depend on it")
      ->check(cli::integer(0, 4096));
  cli::SpectralFitRequest spectral;
  app.add_option("--spectrum", spectral.spectrum_path,
                 "CSV nm,NAME,...: fit chromophore parameters (--param layers[i].chromophores.KEY=LO:HI, at most 5) to "
                 "this reflectance spectrum (docs/spectral.md)");
  app.add_option("--spectrum-column", spectral.column, "--spectrum: the column to fit (default the first after nm)");
  app.add_option("--spectrum-theta-i", spectral.theta_i_deg, "--spectrum: incidence in degrees (default 8)")
      ->check(cli::real(0.0, 90.0, false, true));
  std::vector<lamina::FitParameterSpec> specs;
  std::vector<std::pair<double, std::string>> table_specs;
  std::optional<AlbedoOutputs> albedo_out;  // set in the albedo-texture mode
  try {
    app.parse(argc, argv);
    for (const std::string& p : params) specs.push_back(parse_param(p));
    if (!albedo.texture.empty()) {
      for (const char* other : {"--data", "--table", "--table-sigma", "--out", "--summary", "--coarse-quadrature-points"})
        if (app.count(other) > 0) throw cli::UsageError(std::string(other) + ": not with --albedo-texture");
      albedo.stack = stack_path;
      albedo.settings.axes = specs;
      albedo.settings.albedo = albedo_kind == "total" ? lamina::AlbedoKind::kTotal : lamina::AlbedoKind::kDiffuse;
      // The skin preset's R_hemispherical at 8 points is within 5e-6 of 16 and 32 points (lamina
      // brdf --method adding-doubling), far below a visible difference, at a fifth of the cost.
      albedo.settings.quadrature_points = app.count("--quadrature-points") > 0 ? quadrature_points : 8;
      // The spectral variant solves 85 wavelengths per node: at 4 points the head skin's colours are
      // within Delta E 0.12 of 16 points, at a quarter of 8 points' cost (docs/fitting.md).
      if (lamina::chromophore_axes(specs) && app.count("--quadrature-points") == 0) albedo.settings.quadrature_points = 4;
      albedo_out = check_albedo_usage(albedo);
    } else {
      for (const char* only : {"--texture-decoding", "--albedo", "--out-dir", "--material", "--lookup-nodes", "--unreachable-delta-e", "--threads"})
        if (app.count(only) > 0) throw cli::UsageError(std::string(only) + ": only with --albedo-texture");
    }
    for (const std::string& spec : tables) {  // DEG:FILE
      const std::size_t colon = spec.find(':');
      double theta = 0.0;
      const std::string why = colon == std::string::npos ? std::string("no ':'") : cli::parse_real(spec.substr(0, colon), &theta);
      if (!why.empty() || colon + 1 == spec.size())
        throw cli::UsageError("--table " + cli::in_quotes(spec) + ": expected DEG:TABLE.csv" + (why.empty() ? "" : " (" + why + ")"));
      table_specs.push_back({theta, spec.substr(colon + 1)});
    }
    if (!spectral.spectrum_path.empty()) {
      for (const char* other : {"--data", "--table", "--albedo-texture", "--out"})
        if (app.count(other) > 0) throw cli::UsageError(std::string(other) + ": not with --spectrum");
    } else if (app.count("--spectrum-column") + app.count("--spectrum-theta-i") > 0) {
      throw cli::UsageError("--spectrum-column and --spectrum-theta-i need --spectrum");
    }
    if (!albedo_out && data_path.empty() && tables.empty() && spectral.spectrum_path.empty())
      throw cli::UsageError("no measurements: give --data and/or --table");
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina fit: %s (try 'lamina fit --help')\n", cli::parse_error_line(e).c_str());
    return 2;
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "lamina fit: %s\n", e.what());
    return 2;
  }
  if (albedo_out) return run_albedo_fit(albedo, *albedo_out);
  if (!spectral.spectrum_path.empty()) {
    spectral.stack_path = stack_path;
    spectral.summary_path = summary_path;
    spectral.parameters = specs;
    spectral.quadrature_points = quadrature_points;
    spectral.coarse_quadrature_points = coarse_points;
    return cli::run_fit_spectral(spectral);
  }

  try {
    std::string text;
    if (const std::string why = lamina::read_text_file(stack_path, &text); !why.empty())
      throw lamina::StackFileError(stack_path + ": cannot read the material file: " + why);
    const lamina::StackTemplate t = lamina::parse_stack_template_json(text, stack_path);
    std::vector<lamina::FitMeasurement> data;
    if (!data_path.empty()) data = lamina::load_fit_measurements(data_path);
    for (const auto& [theta, path] : table_specs) {
      std::string ttext;
      if (const std::string why = lamina::read_text_file(path, &ttext); !why.empty())
        throw lamina::FitError(path + ": cannot read the table: " + why);
      const std::vector<lamina::FitMeasurement> bins = lamina::parse_fit_table(ttext, path, theta, table_sigma);
      data.insert(data.end(), bins.begin(), bins.end());
    }
    const std::vector<cli::OutputPath> output_paths = {{"--out", out_path}, {"--summary", summary_path}};
    cli::check_output_paths(output_paths);
    std::vector<cli::InputPath> input_paths = {{"the material file", stack_path}, {"--data", data_path}};
    for (const auto& spec : table_specs) input_paths.push_back({"--table", spec.second});
    cli::check_outputs_not_inputs(output_paths, input_paths);
    lamina::FitSettings settings;
    settings.forward.quadrature_points = quadrature_points;
    settings.coarse_quadrature_points = coarse_points;
    lamina::FitResult r;
    try {
      r = lamina::fit_stack(t, specs, data, settings);
    } catch (const lamina::FitError& e) {  // a parameter's problem: name the file it is in
      throw lamina::FitError(stack_path + ": " + e.what());
    }
    for (const std::string& w : r.warnings) std::fprintf(stderr, "lamina fit: warning: %s\n", cli::one_line(w).c_str());
    const std::string json =
        summary_json(r, data, quadrature_points, summary_path.empty() ? std::string("the report (stdout)") : "--summary '" + summary_path + "'");
    std::string fitted;
    if (!out_path.empty()) {
      nlohmann::json j = nlohmann::json::parse(text);  // parsed once already (parse_stack_template_json)
      lamina::write_fitted_values(j, t, specs, r);
      cli::check_finite_numbers(j, "--out '" + out_path + "'");
      fitted = j.dump(2) + "\n";
    }
    cli::StagedOutputs outputs;  // both files or neither
    if (!out_path.empty()) outputs.write(out_path, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, fitted); });
    if (!summary_path.empty()) outputs.write(summary_path, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, json); });
    outputs.commit();
    if (summary_path.empty()) std::fputs(json.c_str(), stdout);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina fit: %s\n", cli::one_line(e.what()).c_str());
    return 1;
  }
  return 0;
}
