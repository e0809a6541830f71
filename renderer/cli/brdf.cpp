// lamina brdf: the BRDF/BTDF table and energy totals of a layered material (docs/contracts.md,
// "lamina brdf"). One file per subcommand; the physics lives in materials/.
//
// Outputs:
//   --out TABLE.csv      header side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple;
//                        one row per bin and channel (channel r, g, b); theta_o_deg is the bin
//                        centre measured from the normal on that side (0..90 for both reflect and
//                        transmit), phi_o_deg from the light's azimuth. Not written if omitted.
//   --summary TOTALS.json  R_specular, R_diffuse, T_ballistic, T_diffuse, absorbed (RGB triples)
//                        and <key>_stderr; also "method", "theta_i_deg", "phi_i_deg", "samples",
//                        "seed" for provenance, and "walk_ends" (monte-carlo: how many walks
//                        left through the top or bottom, were absorbed, ended by roulette or
//                        were lost). Printed to stdout if omitted.
//                        adding-doubling: the same keys (standard errors 0), "quadrature_points",
//                        "discretisation_error" (the five keys and the three below: |value at N -
//                        value at N/2| nodes; for a heavily truncated forward peak extrapolated
//                        from N, N/2, N/4, said by "discretisation_error_extrapolated") and
//                        R/T/absorbed_hemispherical (diffuse incidence);
//                        with --out also R/T_forward_peak (the delta-M peak's power in the
//                        mirror / ballistic bins).
// Files are written all or none (renderer/cli/outputs.h): each to a temporary in the same folder,
// renamed into place once both are written. Every number is checked by renderer/cli/options.h.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <optional>
#include <utility>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"
#include "materials/stack/stack_file.h"
#include "renderer/batch/brdf_job.h"
#include "renderer/cli/brdf_spectral.h"
#include "renderer/cli/commands.h"
#include "renderer/cli/options.h"
#include "renderer/util/progress.h"
#include "renderer/cli/outputs.h"
#include "renderer/util/finite_output.h"
#include "renderer/util/atomic_file.h"
#include "renderer/util/python_plot.h"

namespace {

using lamina::BrdfOptions;
using lamina::BrdfSide;
using lamina::BrdfTable;
using lamina::Estimate;
using lamina::kChannels;

// The request's options, one CLI11 option per row of lamina::kBrdfOptionTable, bound to the
// member it sets and checked by the command line's validators (renderer/cli/options.h) on the
// row's range; --method into *method (its name).
void add_request_options(CLI::App& app, lamina::BrdfRequest* request, std::string* method) {
  namespace cli = lamina::cli;
  using Kind = lamina::BrdfOptionSpec::Kind;
  for (const lamina::BrdfOptionSpec& spec : lamina::kBrdfOptionTable) {
    CLI::Option* o = nullptr;
    switch (spec.kind) {
      case Kind::Real:
        o = app.add_option(spec.flag, *spec.real(request), spec.help)->check(cli::real(spec.lo, spec.hi, spec.lo_open, spec.hi_open));
        break;
      case Kind::Integer:
        o = app.add_option(spec.flag, *spec.integer(request), spec.help)
                ->check(cli::integer(static_cast<long long>(spec.lo), static_cast<long long>(spec.hi)));
        break;
      case Kind::Count:
        o = app.add_option(spec.flag, *spec.count(request), spec.help)
                ->check(cli::integer(static_cast<long long>(spec.lo), static_cast<long long>(spec.hi)));
        break;
      case Kind::Seed: o = app.add_option(spec.flag, *spec.count(request), spec.help)->check(cli::seed()); break;
      case Kind::Method: o = app.add_option(spec.flag, *method, spec.help)->check(CLI::IsMember(lamina::brdf_method_names())); break;
    }
    if (spec.required) o->required();
  }
}

// %.9g of a finite number; a non-finite one fails the command naming the output, the line and
// the column (docs/contracts.md, "Outputs").
std::string format_number(double v, const std::string& output, std::size_t line, const char* column) {
  lamina::check_finite_output(v, output, "line " + std::to_string(line) + " " + column);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// The table as --out writes it; `output` names it in errors.
std::string table_csv(const BrdfTable& t, const std::string& output) {
  static const char* kChannelNames[kChannels] = {"r", "g", "b"};
  std::ostringstream os;
  os << "side,channel,theta_o_deg,phi_o_deg,value,stderr,single,multiple\n";
  std::size_t line = 1;
  for (int side = 0; side < 2; ++side)
    for (int k = 0; k < t.options.bins_theta; ++k)
      for (int m = 0; m < t.options.bins_phi; ++m) {
        const int b = t.bin_index(static_cast<BrdfSide>(side), k, m);
        for (int c = 0; c < kChannels; ++c) {
          ++line;
          auto number = [&](double v, const char* column) { return format_number(v, output, line, column); };
          os << (side == 0 ? "reflect" : "transmit") << ',' << kChannelNames[c] << ','
             << number(t.theta_centre_deg(k), "theta_o_deg") << ',' << number(t.phi_centre_deg(m), "phi_o_deg") << ','
             << number(t.value[b][c], "value") << ',' << number(t.stderr_[b][c], "stderr") << ','
             << number(t.single[b][c], "single") << ',' << number(t.multiple[b][c], "multiple") << '\n';
        }
      }
  return os.str();
}

std::string totals_json(const BrdfTable& t, const std::string& method, const std::string& output) {
  nlohmann::ordered_json j;
  j["method"] = method;
  j["theta_i_deg"] = t.options.theta_i_deg;
  j["phi_i_deg"] = t.options.phi_i_deg;
  if (method == "monte-carlo") {
    j["samples"] = t.options.samples;
    j["seed"] = t.options.seed;
  }
  auto put = [&](const char* key, const Estimate& e) {
    j[key] = {e.value[0], e.value[1], e.value[2]};
    j[std::string(key) + "_stderr"] = {e.stderr_[0], e.stderr_[1], e.stderr_[2]};
  };
  put("R_specular", t.totals.R_specular);
  put("R_diffuse", t.totals.R_diffuse);
  put("T_ballistic", t.totals.T_ballistic);
  put("T_diffuse", t.totals.T_diffuse);
  put("absorbed", t.totals.absorbed);
  if (method == "monte-carlo") {
    // How the walks ended (WalkResult::End), for diagnosis: many roulette ends mean long walks.
    static const char* kEnds[] = {"exit_top", "exit_bottom", "absorbed", "roulette", "lost"};
    nlohmann::ordered_json ends;
    for (std::size_t e = 0; e < t.ends.size() && e < 5; ++e) ends[kEnds[e]] = t.ends[e];
    j["walk_ends"] = ends;
    // Power still carried by walks past the forced roulette's last phase (materials/brdf/brdf_table.h):
    // R and T may miss up to this much beyond their standard errors.
    put("unresolved", t.totals.unresolved);
    j["unresolved_walks"] = t.totals.unresolved_walks;
  }
  lamina::cli::check_finite_numbers(j, output);
  return j.dump(2) + "\n";
}

// The summary of --method adding-doubling: the keys of totals_json with standard errors 0, the
// diffuse-incidence totals, and the discretisation error estimate (materials/adding_doubling/adding_doubling.h).
std::string adding_doubling_json(const lamina::AddingDoublingEstimate& e, const BrdfOptions& o, int quadrature_points,
                                 bool with_table, const std::string& output) {
  nlohmann::ordered_json j;
  j["method"] = "adding-doubling";
  j["theta_i_deg"] = o.theta_i_deg;
  j["phi_i_deg"] = o.phi_i_deg;
  j["quadrature_points"] = quadrature_points;
  auto rgb = [](const lamina::Spectrum& s) { return nlohmann::ordered_json{s[0], s[1], s[2]}; };
  const lamina::AddingDoublingTotals& t = e.totals;
  const std::pair<const char*, const lamina::Spectrum*> keys[] = {
      {"R_specular", &t.R_specular}, {"R_diffuse", &t.R_diffuse}, {"T_ballistic", &t.T_ballistic},
      {"T_diffuse", &t.T_diffuse},   {"absorbed", &t.absorbed}};
  for (const auto& [key, value] : keys) {
    j[key] = rgb(*value);
    j[std::string(key) + "_stderr"] = rgb(lamina::Spectrum(0.0));
  }
  j["R_hemispherical"] = rgb(t.R_hemispherical);
  j["T_hemispherical"] = rgb(t.T_hemispherical);
  j["absorbed_hemispherical"] = rgb(t.absorbed_hemispherical);
  const lamina::AddingDoublingTotals& d = e.error;
  nlohmann::ordered_json err;
  err["R_specular"] = rgb(d.R_specular);
  err["R_diffuse"] = rgb(d.R_diffuse);
  err["T_ballistic"] = rgb(d.T_ballistic);
  err["T_diffuse"] = rgb(d.T_diffuse);
  err["absorbed"] = rgb(d.absorbed);
  err["R_hemispherical"] = rgb(d.R_hemispherical);
  err["T_hemispherical"] = rgb(d.T_hemispherical);
  err["absorbed_hemispherical"] = rgb(d.absorbed_hemispherical);
  j["discretisation_error"] = err;
  if (e.extrapolated)  // a heavily truncated forward peak (adding_doubling.h)
    j["discretisation_error_extrapolated"] = {{"points", {quadrature_points, std::max(2, quadrature_points / 2),
                                                          std::max(2, quadrature_points / 4)}},
                                              {"delta_m_forward_peak", e.forward_truncation}};
  if (with_table) {
    j["R_forward_peak"] = rgb(t.R_forward_peak);
    j["T_forward_peak"] = rgb(t.T_forward_peak);
  }
  lamina::cli::check_finite_numbers(j, output);
  return j.dump(2) + "\n";
}

// --plot: the table and totals as the files would hold them, drawn by the Python package
// (renderer/util/python_plot.h) before any output is written.
void plot_brdf(const std::string& csv, const std::string& json, const std::string& plot_path) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("lamina_brdf_plot_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  try {
    lamina::write_file_atomically((dir / "table.csv").string(), csv);
    lamina::write_file_atomically((dir / "totals.json").string(), json);
    lamina::run_python_plot({"brdf", (dir / "table.csv").string(), (dir / "totals.json").string(), plot_path});
  } catch (...) {
    fs::remove_all(dir);
    throw;
  }
  fs::remove_all(dir);
}

}  // namespace

int run_brdf(int argc, char** argv) {
  CLI::App app{
      "BRDF/BTDF table and energy totals of a layered material for light from (theta_i, phi_i).\n"
      "first-order: the analytic zeroth- and first-order solution (single scattering; 'absorbed'\n"
      "then also holds the light of higher orders). monte-carlo: the random walk, all orders,\n"
      "single and multiple scattering reported apart, with standard errors. adding-doubling: the\n"
      "deterministic solution, all orders, with a discretisation error (the table costs one\n"
      "solution per azimuthal mode).",
      "lamina brdf"};
  std::string stack_path, method = lamina::brdf_method_name(lamina::BrdfRequest{}.method), out_path, summary_path, wavelengths;
  lamina::BrdfRequest request;  // the table's options (renderer/batch/brdf_job.h) are parsed into it
  namespace cli = lamina::cli;
  app.add_option("STACK.json", stack_path, "material file (JSON, docs/contracts.md)")->required();
  add_request_options(app, &request, &method);
  app.add_option("--out", out_path, "write the table as CSV here");
  app.add_option("--summary", summary_path, "write the totals as JSON here (default: stdout)");
  std::string plot_path;
  app.add_option("--plot", plot_path,
                 "draw the BRDF and BTDF (plane of incidence, hemisphere, Lambert for comparison) as a PNG here "
                 "(with the Python package's matplotlib, docs/python.md)");
  app.add_option("--wavelengths", wavelengths,
                 "FIRST:LAST:STEP nm: the totals per wavelength (adding-doubling only, no --out); the material may "
                 "give layers by chromophores (docs/spectral.md)");

  try {
    app.parse(argc, argv);
    lamina::parse_brdf_method(method, &request.method);  // one of the three names (checked by CLI11)
    try {
      lamina::check_brdf_request(request);
    } catch (const std::invalid_argument& e) {
      throw cli::UsageError(e.what());
    }
    if (!wavelengths.empty()) {
      cli::check_wavelengths(wavelengths);
      if (method != "adding-doubling" || !out_path.empty())
        throw cli::UsageError("--wavelengths needs --method adding-doubling and no --out");
    }
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina brdf: %s (try 'lamina brdf --help')\n", cli::parse_error_line(e).c_str());
    return 2;
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "lamina brdf: %s\n", e.what());
    return 2;
  }

  BrdfOptions& options = request.options;
  if (!wavelengths.empty())
    return cli::run_brdf_spectral(
        {stack_path, summary_path, wavelengths, options.theta_i_deg, options.phi_i_deg, request.quadrature_points});
  try {
    if (method != "monte-carlo" && app.count("--samples") + app.count("--seed") > 0)
      std::fprintf(stderr, "lamina brdf: note: --samples and --seed are ignored by --method %s\n", method.c_str());
    if (method != "adding-doubling" && app.count("--quadrature-points") > 0)
      std::fprintf(stderr, "lamina brdf: note: --quadrature-points is only used by --method adding-doubling\n");

    const lamina::LayerStack stack = lamina::load_stack_file(stack_path);
    lamina::check_brdf_method(stack, stack_path, request.method);
    // Fail before a long computation if an output cannot be written.
    const std::vector<cli::OutputPath> output_paths = {{"--out", out_path}, {"--summary", summary_path}, {"--plot", plot_path}};
    cli::check_output_paths(output_paths);
    cli::check_outputs_not_inputs(output_paths, {{"the material file", stack_path}});
    request.table = !out_path.empty() || !plot_path.empty();
    std::optional<lamina::Progress> progress;
    if (request.method == lamina::BrdfMethod::MonteCarlo) {
      progress.emplace("brdf", options.samples);
      options.on_progress = [&](std::uint64_t n) { progress->advance(n); };
    }
    const lamina::BrdfResult result = lamina::compute_brdf(stack, stack_path, request);
    if (progress) progress->finish();
    for (const std::string& note : result.notes) std::fprintf(stderr, "lamina brdf: note: %s\n", note.c_str());
    const BrdfTable& table = result.table;
    // How errors name the outputs (the summary goes to stdout without --summary).
    const std::string out_name = "--out '" + out_path + "'", plot_name = "--plot '" + plot_path + "' (its table)";
    const std::string summary_name = summary_path.empty() ? std::string("the summary (stdout)") : "--summary '" + summary_path + "'";
    if (request.method == lamina::BrdfMethod::AddingDoubling) {
      const std::string csv = out_path.empty() ? "" : table_csv(table, out_name);
      const std::string json = adding_doubling_json(result.adding_doubling, options, request.quadrature_points, !out_path.empty(), summary_name);
      if (!plot_path.empty()) plot_brdf(table_csv(table, plot_name), json, plot_path);
      cli::StagedOutputs outputs;  // both files or neither
      if (!out_path.empty()) outputs.write(out_path, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, csv); });
      if (!summary_path.empty()) outputs.write(summary_path, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, json); });
      outputs.commit();
      if (summary_path.empty()) std::fputs(json.c_str(), stdout);
      return 0;
    }
    const std::string json = totals_json(table, method, summary_name);
    if (!plot_path.empty()) plot_brdf(table_csv(table, plot_name), json, plot_path);
    cli::StagedOutputs outputs;  // both files or neither
    if (!out_path.empty()) {
      const std::string csv = table_csv(table, out_name);
      outputs.write(out_path, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, csv); });
    }
    if (!summary_path.empty()) outputs.write(summary_path, [&](const std::string& tmp) { lamina::write_file_atomically(tmp, json); });
    outputs.commit();
    if (summary_path.empty()) std::fputs(json.c_str(), stdout);
  } catch (const lamina::StackFileError& e) {
    std::fprintf(stderr, "lamina brdf: %s\n", cli::one_line(e.what()).c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina brdf: %s\n", cli::one_line(e.what()).c_str());
    return 1;
  }
  return 0;
}
