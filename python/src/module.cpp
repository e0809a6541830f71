// lamina._lamina: the C++ half of the Python package (docs/python.md). Each function calls the
// library function the command line calls (renderer/cli/*.cpp parse and print around the same
// calls), so that the package's numbers equal the CLI's bit for bit; python/lamina/__init__.py
// adds the progress display, Ctrl-C and numpy conveniences. Every long call releases the GIL;
// it reports progress into a JobState that Python polls and that can ask the work to stop.
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/function.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>
#include <nlohmann/json.hpp>

#include "materials/fit/stack_fit.h"
#include "materials/stack/decimal.h"
#include "materials/stack/stack_file.h"
#include "renderer/batch/brdf_job.h"
#include "renderer/image/denoise.h"
#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/render/render_job.h"
#include "renderer/render/spectral_option.h"
#include "renderer/render/walk_option_table.h"
#include "renderer/util/version.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace lamina {
namespace {

// Thrown from a progress callback when Python asked the work to stop (Ctrl-C).
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled") {}
};

// Shared between the C++ work (any thread) and Python's polling loop.
struct JobState {
  std::atomic<std::uint64_t> done{0}, total{0};
  std::atomic<bool> cancel{false};
  void advance(std::uint64_t n) {
    done += n;
    if (cancel) throw Cancelled();
  }
};

using FloatArray = nb::ndarray<nb::numpy, float>;
using DoubleArray = nb::ndarray<nb::numpy, double>;

// A numpy array owning a copy moved out of `values`, of the given shape.
template <class T>
nb::ndarray<nb::numpy, T> to_numpy(std::vector<T>&& values, std::initializer_list<std::size_t> shape) {
  auto* owned = new std::vector<T>(std::move(values));
  nb::capsule owner(owned, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::ndarray<nb::numpy, T>(owned->data(), shape.size(), shape.begin(), owner);
}

// An (height, width, 3) float32 array (C order) as an Image.
Image image_from(const nb::ndarray<float, nb::shape<-1, -1, 3>, nb::c_contig, nb::device::cpu>& a) {
  Image image(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)));
  std::copy(a.data(), a.data() + a.size(), image.rgb.begin());
  return image;
}
FloatArray image_to_numpy(Image&& image) {
  const std::size_t h = image.height, w = image.width;
  return to_numpy(std::move(image.rgb), {h, w, 3});
}

nb::tuple rgb(const Spectrum& s) { return nb::make_tuple(s[0], s[1], s[2]); }

// ---------------------------------------------------------------------------------------------
// Stacks: the parsed stack and the text it was parsed from (fit needs the template).

struct PyStack {
  LayerStack stack;
  std::string text, source;
};

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StackFileError(path + ": cannot open");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

PyStack stack_load(const std::string& path) {
  PyStack s;
  s.stack = load_stack_file(path);  // the CLI's loader and messages
  s.text = read_text(path);
  s.source = path;
  return s;
}

PyStack stack_parse(const std::string& text, const std::string& source) {
  return PyStack{parse_stack_json(text, source), text, source};
}

// ---------------------------------------------------------------------------------------------
// lamina brdf

nb::dict estimate_dict(const Estimate& e) {
  nb::dict d;
  d["value"] = rgb(e.value);
  d["stderr"] = rgb(e.stderr_);
  return d;
}

// Bins as arrays of shape (2 sides, bins_theta, bins_phi, 3 channels).
DoubleArray bins(const BrdfTable& t, const std::vector<Spectrum>& v) {
  std::vector<double> out;
  out.reserve(v.size() * 3);
  for (const Spectrum& s : v)
    for (int c = 0; c < 3; ++c) out.push_back(s[c]);
  return to_numpy(std::move(out), {2, static_cast<std::size_t>(t.options.bins_theta), static_cast<std::size_t>(t.options.bins_phi), 3});
}

// The totals of `lamina brdf --summary`, by key: value and stderr (and adding-doubling's
// discretisation error); the method's extra keys go into `d`.
nb::dict brdf_totals(BrdfMethod method, const BrdfResult& r, nb::dict& d) {
  nb::dict totals;
  if (method == BrdfMethod::AddingDoubling) {
    const AddingDoublingTotals& t = r.adding_doubling.totals;
    const AddingDoublingTotals& e = r.adding_doubling.error;
    auto put = [&](const char* key, const Spectrum& v, const Spectrum& err) {
      nb::dict x;
      x["value"] = rgb(v);
      x["stderr"] = rgb(Spectrum(0.0));
      x["discretisation_error"] = rgb(err);
      totals[key] = x;
    };
    put("R_specular", t.R_specular, e.R_specular);
    put("R_diffuse", t.R_diffuse, e.R_diffuse);
    put("T_ballistic", t.T_ballistic, e.T_ballistic);
    put("T_diffuse", t.T_diffuse, e.T_diffuse);
    put("absorbed", t.absorbed, e.absorbed);
    put("R_hemispherical", t.R_hemispherical, e.R_hemispherical);
    put("T_hemispherical", t.T_hemispherical, e.T_hemispherical);
    put("absorbed_hemispherical", t.absorbed_hemispherical, e.absorbed_hemispherical);
    if (r.has_table) {
      d["R_forward_peak"] = rgb(t.R_forward_peak);
      d["T_forward_peak"] = rgb(t.T_forward_peak);
    }
  } else {
    const EnergyTotals& t = r.table.totals;
    totals["R_specular"] = estimate_dict(t.R_specular);
    totals["R_diffuse"] = estimate_dict(t.R_diffuse);
    totals["T_ballistic"] = estimate_dict(t.T_ballistic);
    totals["T_diffuse"] = estimate_dict(t.T_diffuse);
    totals["absorbed"] = estimate_dict(t.absorbed);
    if (method == BrdfMethod::MonteCarlo) {
      totals["unresolved"] = estimate_dict(t.unresolved);
      d["unresolved_walks"] = t.unresolved_walks;
      static const char* kEnds[] = {"exit_top", "exit_bottom", "absorbed", "roulette", "lost"};
      nb::dict ends;
      for (std::size_t e = 0; e < r.table.ends.size() && e < 5; ++e) ends[kEnds[e]] = r.table.ends[e];
      d["walk_ends"] = ends;
    }
  }
  return totals;
}

// A bound of a range as the command line's messages write it: integers in full, others in %g.
std::string bound_text(double v) {
  if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  char buf[40];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// One keyword argument of lamina.brdf, checked against its row of kBrdfOptionTable
// (renderer/batch/brdf_job.h) as the command line's validators check the flag: TypeError for a
// wrong type, ValueError in the command line's words for a value out of range.
void set_brdf_option(const BrdfOptionSpec& spec, const std::string& key, nb::handle value, BrdfRequest* request) {
  using Kind = BrdfOptionSpec::Kind;
  const std::string type = nb::cast<std::string>(nb::handle(value.type()).attr("__name__"));
  const bool is_int = nb::isinstance<nb::int_>(value) && !nb::isinstance<nb::bool_>(value);
  if (spec.kind == Kind::Method) {
    if (!nb::isinstance<nb::str>(value)) throw nb::type_error((key + ": expected a str, got " + type).c_str());
    const std::string name = nb::cast<std::string>(value);
    if (!parse_brdf_method(name, &request->method))
      throw std::invalid_argument(key + ": expected first-order, monte-carlo or adding-doubling (got '" + name + "')");
  } else if (spec.kind == Kind::Real) {
    if (!is_int && !nb::isinstance<nb::float_>(value)) throw nb::type_error((key + ": expected a number, got " + type).c_str());
    const double v = nb::cast<double>(value);
    const bool inside = (spec.lo_open ? v > spec.lo : v >= spec.lo) && (spec.hi_open ? v < spec.hi : v <= spec.hi);
    if (!std::isfinite(v) || !inside) {
      const bool bounded = std::isfinite(spec.lo) || std::isfinite(spec.hi);
      throw std::invalid_argument(key + ": must be a finite number" +
                                  (bounded ? std::string(" in ") + (spec.lo_open ? "(" : "[") + bound_text(spec.lo) + ", " +
                                                 bound_text(spec.hi) + (spec.hi_open ? ")" : "]")
                                           : std::string()) +
                                  " (got " + nb::cast<std::string>(nb::repr(value)) + ")");
    }
    *spec.real(request) = v;
  } else {
    if (!is_int) throw nb::type_error((key + ": expected an integer, got " + type).c_str());
    // Read from its decimal text by the command line's parsers (materials/stack/decimal.h).
    const std::string text = nb::cast<std::string>(nb::str(value));
    const bool seed = spec.kind == Kind::Seed;
    std::uint64_t u = 0;
    long long v = 0;
    const bool inside = seed ? parse_u64(text, &u).empty() : parse_integer(text, &v).empty() && v >= spec.lo && v <= spec.hi;
    if (!inside)
      throw std::invalid_argument(key + ": must be an integer " +
                                  (seed ? std::string("from 0 to 18446744073709551615")
                                        : "between " + bound_text(spec.lo) + " and " + bound_text(spec.hi)) +
                                  " (got " + text + ")");
    if (spec.kind == Kind::Integer) *spec.integer(request) = static_cast<int>(v);
    else *spec.count(request) = seed ? u : static_cast<std::uint64_t>(v);
  }
}

// The rows of kBrdfOptionTable as Python sees them: (keyword, default, help, required).
nb::list brdf_option_table() {
  nb::list rows;
  const BrdfRequest defaults;
  for (const BrdfOptionSpec& spec : kBrdfOptionTable) {
    BrdfRequest r = defaults;
    nb::object value;
    switch (spec.kind) {
      case BrdfOptionSpec::Kind::Real: value = nb::float_(*spec.real(&r)); break;
      case BrdfOptionSpec::Kind::Integer: value = nb::int_(*spec.integer(&r)); break;
      case BrdfOptionSpec::Kind::Count:
      case BrdfOptionSpec::Kind::Seed: value = nb::int_(*spec.count(&r)); break;
      case BrdfOptionSpec::Kind::Method: value = nb::str(brdf_method_name(r.method)); break;
    }
    rows.append(nb::make_tuple(brdf_option_keyword(spec), value, spec.help, spec.required));
  }
  return rows;
}

nb::dict brdf(const PyStack& stack, nb::dict options, bool table, JobState* state) {
  BrdfRequest request;
  for (auto [key, value] : options) {
    const std::string k = nb::cast<std::string>(key);
    const BrdfOptionSpec* spec = nullptr;
    for (const BrdfOptionSpec& row : kBrdfOptionTable)
      if (brdf_option_keyword(row) == k) spec = &row;
    if (!spec) throw nb::type_error(("brdf() got an unexpected keyword argument '" + k + "'").c_str());
    set_brdf_option(*spec, k, value, &request);
  }
  for (const BrdfOptionSpec& row : kBrdfOptionTable)
    if (row.required && !options.contains(brdf_option_keyword(row).c_str()))
      throw nb::type_error(("brdf() missing the argument '" + brdf_option_keyword(row) + "'").c_str());
  check_brdf_request(request);  // the command line's message, as a ValueError
  request.table = request.method == BrdfMethod::AddingDoubling ? table : true;
  BrdfOptions& o = request.options;
  if (state) {
    state->total = request.method == BrdfMethod::MonteCarlo ? o.samples : 0;
    o.on_progress = [state](std::uint64_t n) { state->advance(n); };
  }
  BrdfResult r;
  {
    nb::gil_scoped_release release;
    r = compute_brdf(stack.stack, stack.source, request);
  }
  nb::dict d;
  nb::dict used;  // every option's value as computed, by keyword
  for (const BrdfOptionSpec& row : kBrdfOptionTable) {
    const std::string text = brdf_option_text(row, request);
    if (row.kind == BrdfOptionSpec::Kind::Real) used[brdf_option_keyword(row).c_str()] = std::stod(text);
    else if (row.kind == BrdfOptionSpec::Kind::Method) used[brdf_option_keyword(row).c_str()] = text;
    else used[brdf_option_keyword(row).c_str()] = nb::int_(nb::str(text.c_str()));
  }
  d["options"] = used;
  d["method"] = brdf_method_name(request.method);
  d["notes"] = r.notes;
  d["totals"] = brdf_totals(request.method, r, d);
  if (r.has_table) {
    const BrdfTable& t = r.table;
    d["value"] = bins(t, t.value);
    d["stderr"] = bins(t, t.stderr_);
    d["single"] = bins(t, t.single);
    d["multiple"] = bins(t, t.multiple);
    std::vector<double> theta, phi, psa;
    const int bins_theta = o.bins_theta, bins_phi = o.bins_phi;
    for (int k = 0; k < bins_theta; ++k) {
      theta.push_back(t.theta_centre_deg(k));
      psa.push_back(t.projected_solid_angle(k));
    }
    for (int m = 0; m < bins_phi; ++m) phi.push_back(t.phi_centre_deg(m));
    d["theta_o_deg"] = to_numpy(std::move(theta), {static_cast<std::size_t>(bins_theta)});
    d["phi_o_deg"] = to_numpy(std::move(phi), {static_cast<std::size_t>(bins_phi)});
    d["projected_solid_angle"] = to_numpy(std::move(psa), {static_cast<std::size_t>(bins_theta)});
  }
  return d;
}

// ---------------------------------------------------------------------------------------------
// lamina fit (measurements mode)

nb::dict fit(const PyStack& stack, const std::string& data_text, const std::string& data_source,
             const std::vector<std::tuple<std::string, double, double>>& params, int quadrature_points,
             int coarse_quadrature_points) {
  std::vector<FitParameterSpec> specs;
  for (const auto& [path, lo, hi] : params) specs.push_back(FitParameterSpec{path, lo, hi});
  FitResult r;
  std::string fitted;
  std::vector<FitMeasurement> data;
  {
    nb::gil_scoped_release release;
    const StackTemplate t = parse_stack_template_json(stack.text, stack.source);
    data = parse_fit_measurements(data_text, data_source);
    FitSettings settings;
    settings.forward.quadrature_points = quadrature_points;
    settings.coarse_quadrature_points = coarse_quadrature_points;
    try {
      r = fit_stack(t, specs, data, settings);
    } catch (const FitError& e) {  // a parameter's problem: name the file it is in, as the CLI
      throw FitError(stack.source + ": " + e.what());
    }
    nlohmann::json j = nlohmann::json::parse(stack.text);
    write_fitted_values(j, t, specs, r);
    fitted = j.dump(2) + "\n";
  }
  nb::dict d;
  nb::list ps;
  for (std::size_t k = 0; k < r.unknowns.size(); ++k) {
    nb::dict p;
    p["name"] = r.unknowns[k].name;
    p["value"] = r.value[k];
    p["sigma"] = r.sigma[k];
    p["lower"] = r.unknowns[k].lower;
    p["upper"] = r.unknowns[k].upper;
    p["start"] = r.unknowns[k].start;
    p["at_bound"] = static_cast<bool>(r.at_bound[k]);
    ps.append(p);
  }
  d["parameters"] = ps;
  d["chi2"] = r.chi2;
  d["dof"] = r.dof;
  d["evaluations"] = r.evaluations;
  d["coarse_evaluations"] = r.coarse_evaluations;
  d["model"] = r.model;
  d["residual"] = r.residual;
  d["warnings"] = r.warnings;
  d["fitted_json"] = fitted;
  return d;
}

// ---------------------------------------------------------------------------------------------
// lamina render

// The walk's options by their `lamina render` flags, each checked against its row of
// kWalkOptionTable (renderer/render/walk_option_table.h) as the CLI's validators do.
void set_walk_option(const WalkOptionSpec& spec, const std::string& flag, const std::string& value, RandomWalkOptions* walk) {
  if (spec.kind == WalkOptionSpec::Kind::Switch) {
    if (value != spec.on_word && value != spec.off_word)
      throw std::invalid_argument(flag + ": expected " + spec.on_word + " or " + spec.off_word);
    set_walk_switch(spec, value, walk);
    return;
  }
  std::size_t used = 0;
  double v = std::nan("");
  try {
    v = std::stod(value, &used);
  } catch (const std::exception&) {
  }
  const bool integer = spec.kind == WalkOptionSpec::Kind::Integer;
  const bool inside = (spec.lo_open ? v > spec.lo : v >= spec.lo) && (spec.hi_open ? v < spec.hi : v <= spec.hi);
  if (used != value.size() || !inside || (integer && v != std::floor(v)))
    throw std::invalid_argument(flag + ": must be " + (integer ? "an integer" : "a finite number") + " in " +
                                (spec.lo_open ? "(" : "[") + std::to_string(spec.lo) + ", " + std::to_string(spec.hi) +
                                (spec.hi_open ? ")" : "]") + " (got '" + value + "')");
  if (integer) walk->*spec.integer_member = static_cast<int>(v);
  else walk->*spec.real_member = v;
}

RandomWalkOptions walk_options_from(const std::vector<std::pair<std::string, std::string>>& options) {
  RandomWalkOptions walk;
  for (const auto& [flag, value] : options) {
    bool found = false;
    for (const WalkOptionSpec& spec : kWalkOptionTable)
      if (flag == spec.flag) {
        set_walk_option(spec, flag, value, &walk);
        found = true;
      }
    if (!found) throw std::invalid_argument("unknown walk option '" + flag + "'");
  }
  return walk;
}

// The named choices of a render, parsed by the library's parsers (the CLI's).
void set_render_choices(const std::string& subsurface, double tolerance, const std::string& table_method,
                        const std::string& aovs, const std::string& tone_curve, RenderRequest* request) {
  std::string bad;
  if (!parse_aov_names(aovs, &request->settings.aovs, &bad))
    throw std::invalid_argument("aovs '" + aovs + "': unknown AOV '" + bad + "' (expected albedo, normal, depth, variance, all or none)");
  SubsurfaceChoice choice;
  if (!parse_subsurface_choice(subsurface, &choice))
    throw std::invalid_argument("subsurface '" + subsurface + "': expected " + subsurface_choice_expected());
  choice.tolerance = choice.automatic ? tolerance : 0.0;
  request->subsurface = choice;
  if (table_method != "adding-doubling" && table_method != "walk")
    throw std::invalid_argument("table_method '" + table_method + "': expected adding-doubling or walk");
  request->table_method = table_method == "walk" ? TableSettings::Method::MonteCarlo : TableSettings::Method::AddingDoubling;
  if (!parse_tone_curve(tone_curve, &request->tone_map.curve))
    throw std::invalid_argument("tone_curve '" + tone_curve + "': expected filmic or clamp");
}

// The image (moved into numpy arrays), its header and the render's numbers.
nb::dict render_result_dict(RenderResult&& r, const std::vector<std::string>& info, const std::vector<std::string>& warnings) {
  nb::dict d;
  const std::size_t h = r.image.height, w = r.image.width;
  d["rgb"] = image_to_numpy(std::move(r.image));
  nb::list channels;
  for (ExtraChannel& c : r.channels) {
    const std::string name = c.name;
    channels.append(nb::make_tuple(name, to_numpy(std::move(c.values), {h, w})));
  }
  d["channels"] = channels;
  d["metadata"] = r.metadata;
  d["window"] = nb::make_tuple(r.window.x, r.window.y, r.window.full_width, r.window.full_height);
  d["seconds"] = r.seconds;
  d["camera"] = r.camera;
  d["info"] = info;
  d["warnings"] = warnings;
  d["invalid_samples"] = r.stats.invalid_samples;
  d["clamped_samples"] = r.stats.clamped_samples;
  d["layered_materials"] = r.layered_materials;
  return d;
}

nb::dict render(const std::string& scene, const std::string& out, const std::string& png, int width, int height, int spp,
                std::uint64_t seed, int threads, const std::string& subsurface, double tolerance, const std::string& camera,
                const std::string& materials, const std::string& env, int max_depth, const std::string& aovs,
                const std::string& cache, const std::string& table_method, double noise_threshold, int pilot_spp,
                double clamp, double time_limit, const std::vector<int>& crop, double exposure,
                const std::string& tone_curve, const std::vector<std::pair<std::string, std::string>>& walk_options,
                const std::vector<std::tuple<std::string, std::string, std::string>>& inline_stacks, bool spectral,
                const std::string& command_line, const std::vector<std::string>& given, JobState* state) {
  RenderRequest request;
  RenderSettings& s = request.settings;
  s.width = width;
  s.height = height;
  s.spp = spp;
  s.seed = seed;
  s.threads = threads;
  s.max_depth = max_depth;
  s.noise_threshold = noise_threshold;
  s.pilot_spp = pilot_spp;
  s.clamp = clamp;
  s.time_limit = time_limit;
  if (!crop.empty()) {
    if (crop.size() != 4) throw std::invalid_argument("crop: expected (X0, Y0, X1, Y1)");
    s.crop = PixelRegion{crop[0], crop[1], crop[2], crop[3]};
  }
  request.tone_map.exposure = exposure;
  set_render_choices(subsurface, tolerance, table_method, aovs, tone_curve, &request);
  request.walk = walk_options_from(walk_options);
  request.scene_path = scene;
  request.out_path = out;
  request.png_path = png;
  request.write_files = !out.empty();
  request.camera_name = camera;
  request.materials_map_path = materials;
  for (const auto& [material, json, source] : inline_stacks) request.inline_stacks.push_back({material, json, source});
  request.env = env;
  request.cache_dir = cache;
  request.command_line = command_line;
  request.given = given;  // the combinations are checked by render_job (renderer/render/render_request_check.h)
  s.spectral = spectral;
  if (spectral) request.given.push_back(kSpectralOption.flag);
  std::vector<std::string> info, warnings;
  std::mutex lines;
  RenderLog log;
  log.info = [&](const std::string& line) { std::lock_guard<std::mutex> lock(lines); info.push_back(line); };
  log.warning = [&](const std::string& line) { std::lock_guard<std::mutex> lock(lines); warnings.push_back(line); };
  request.on_progress = [state](std::uint64_t done, std::uint64_t total) {
    if (!state) return;
    state->total = total;
    state->done = done;
    if (state->cancel) throw Cancelled();
  };
  request.cancel = state ? &state->cancel : nullptr;  // stops within a path (renderer/render/film.h)
  RenderResult r;
  {
    nb::gil_scoped_release release;
    try {
      r = render_job(request, log);
    } catch (const RenderCancelled&) {
      throw Cancelled();
    }
  }
  return render_result_dict(std::move(r), info, warnings);
}

// ---------------------------------------------------------------------------------------------
// Images: files, comparison, denoising.

using InputImage = nb::ndarray<float, nb::shape<-1, -1, 3>, nb::c_contig, nb::device::cpu>;
using InputPlane = nb::ndarray<float, nb::shape<-1, -1>, nb::c_contig, nb::device::cpu>;

void write_exr_file(const std::string& path, const InputImage& rgb, const std::vector<std::pair<std::string, std::string>>& metadata,
                    const std::vector<std::pair<std::string, InputPlane>>& channels, std::tuple<int, int, int, int> window) {
  const Image image = image_from(rgb);
  std::vector<ExtraChannel> extra;
  for (const auto& [name, plane] : channels) {
    if (plane.shape(0) != rgb.shape(0) || plane.shape(1) != rgb.shape(1))
      throw std::invalid_argument("channel '" + name + "': its shape differs from the image's");
    extra.push_back({name, std::vector<float>(plane.data(), plane.data() + plane.size())});
  }
  const DataWindow w{std::get<0>(window), std::get<1>(window), std::get<2>(window), std::get<3>(window)};
  nb::gil_scoped_release release;
  write_exr(path, image, metadata, extra, w);
}

nb::dict read_exr_file(const std::string& path) {
  ChannelImage c;
  Metadata meta;
  {
    nb::gil_scoped_release release;
    c = read_channels(path);
    meta = read_metadata(path);
  }
  nb::dict d;
  d["names"] = c.names;
  d["values"] = to_numpy(std::move(c.values), {static_cast<std::size_t>(c.height), static_cast<std::size_t>(c.width), c.names.size()});
  d["metadata"] = meta;
  return d;
}

nb::tuple read_image_file(const std::string& path) {
  int channels = 0;
  Image image;
  {
    nb::gil_scoped_release release;
    image = read_image(path, &channels);
  }
  return nb::make_tuple(image_to_numpy(std::move(image)), channels);
}

nb::dict compare(const InputImage& reference, const InputImage& test, double epsilon) {
  const Image a = image_from(reference), b = image_from(test);
  CompareMetrics m;
  {
    nb::gil_scoped_release release;
    m = compare_images(a, b, epsilon);
  }
  nb::dict d;
  d["guard_floor"] = m.guard_floor;
  d["mean_relative"] = m.mean_relative;
  d["rms_relative"] = m.rms_relative;
  d["max_abs_relative"] = m.max_abs_relative;
  d["mae"] = m.mae;
  d["mse"] = m.mse;
  d["rmse"] = m.rmse;
  d["ssim"] = m.ssim;
  return d;
}

FloatArray relative_luminance(const InputImage& reference, const InputImage& test, double epsilon) {
  const Image a = image_from(reference), b = image_from(test);
  std::vector<float> rel = relative_luminance_difference(a, b, epsilon);
  return to_numpy(std::move(rel), {static_cast<std::size_t>(a.height), static_cast<std::size_t>(a.width)});
}

nb::tuple denoise_image(const InputImage& colour, nb::object albedo, nb::object normal, int threads) {
  const Image c = image_from(colour);
  Image a, n;
  DenoiseInput input;
  input.colour = &c;
  input.threads = threads;
  if (!albedo.is_none()) {
    a = image_from(nb::cast<InputImage>(albedo));
    input.albedo = &a;
    if (!normal.is_none()) {
      n = image_from(nb::cast<InputImage>(normal));
      input.normal = &n;
    }
  }
  DenoiseResult r;
  {
    nb::gil_scoped_release release;
    r = denoise(input);
  }
  return nb::make_tuple(image_to_numpy(std::move(r.image)), r.library, r.version);
}

}  // namespace
}  // namespace lamina

NB_MODULE(_lamina, m) {
  using namespace lamina;
  m.doc() = "The C++ half of the lamina package; use the functions of `lamina` (docs/python.md).";
  m.attr("__version__") = lamina_version();

  // Bad input raises with the command line's one-line messages.
  nb::exception<StackFileError>(m, "StackFileError", PyExc_ValueError);
  nb::exception<FitError>(m, "FitError", PyExc_ValueError);
  nb::exception<ImageIoError>(m, "ImageIoError", PyExc_OSError);
  nb::exception<DenoiseError>(m, "DenoiseError", PyExc_RuntimeError);
  nb::exception<Cancelled>(m, "Cancelled", PyExc_KeyboardInterrupt);

  nb::class_<JobState>(m, "JobState", "Progress of a running call, and the request to stop it.")
      .def(nb::init<>())
      .def_prop_ro("done", [](const JobState& s) { return s.done.load(); })
      .def_prop_ro("total", [](const JobState& s) { return s.total.load(); })
      .def("cancel", [](JobState& s) { s.cancel = true; }, "Ask the work to stop at its next progress report.");

  nb::class_<Layer>(m, "Layer", "One layer of a stack (read-only; values per RGB channel).")
      .def_ro("name", &Layer::name)
      .def_ro("ior", &Layer::ior)
      .def_ro("thickness", &Layer::thickness, "mm; inf for a semi-infinite layer")
      .def_prop_ro("sigma_a", [](const Layer& l) { return rgb(l.sigma_a); }, "absorption, 1/mm")
      .def_prop_ro("sigma_s", [](const Layer& l) { return rgb(l.sigma_s()); }, "scattering, 1/mm (all lobes)")
      .def_prop_ro("albedo", [](const Layer& l) { return rgb(l.albedo()); }, "single-scattering albedo")
      .def_prop_ro("semi_infinite", &Layer::semi_infinite);

  nb::class_<PyStack>(m, "Stack", "A layered material (docs/contracts.md, \"Material file\").")
      .def_static("load", &stack_load, "path"_a, "Reads a material file (its errors: StackFileError).")
      .def_static("parse", &stack_parse, "text"_a, "source"_a, "Parses a material file's text; errors name `source`.")
      .def_prop_ro("name", [](const PyStack& s) { return s.stack.name; })
      .def_prop_ro("above_ior", [](const PyStack& s) { return s.stack.above_ior; })
      .def_prop_ro("top_roughness", [](const PyStack& s) { return s.stack.top_roughness; })
      .def_prop_ro("layers", [](const PyStack& s) { return s.stack.layers; })
      .def_prop_ro("transmits", [](const PyStack& s) { return s.stack.transmits(); })
      .def_ro("json", &PyStack::text, "the material file's text")
      .def_ro("source", &PyStack::source, "the file (or name) it came from; errors name it");

  m.def("brdf", &brdf, "lamina brdf: totals and bins (renderer/batch/brdf_job.h); options by keyword, as brdf_options() lists them.",
        "stack"_a, "options"_a, "table"_a, "state"_a.none());
  m.def("brdf_options", &brdf_option_table,
        "The options of lamina brdf (kBrdfOptionTable): (keyword, default, help, required) per row.");
  m.def("fit", &fit, "lamina fit with measurements (materials/fit/stack_fit.h).", "stack"_a, "data_text"_a, "data_source"_a, "params"_a, "quadrature_points"_a,
        "coarse_quadrature_points"_a);
  m.def("render", &render, "lamina render without its argument parsing (renderer/render/render_job.h).", "scene"_a, "out"_a, "png"_a, "width"_a, "height"_a, "spp"_a, "seed"_a, "threads"_a,
        "subsurface"_a, "tolerance"_a, "camera"_a, "materials"_a, "env"_a, "max_depth"_a, "aovs"_a, "cache"_a,
        "table_method"_a, "noise_threshold"_a, "pilot_spp"_a, "clamp"_a, "time_limit"_a, "crop"_a, "exposure"_a, "tone_curve"_a, "walk_options"_a, "inline_stacks"_a, "spectral"_a, "command_line"_a,
        "given"_a, "state"_a.none());
  m.def("write_exr", &write_exr_file, "A float EXR with extra channels and header, atomically.", "path"_a, "rgb"_a, "metadata"_a, "channels"_a, "window"_a);
  m.def("read_exr", &read_exr_file, "Every channel of an EXR and its header.", "path"_a);
  m.def("read_image", &read_image_file, "An image file as linear RGB, and its number of colour channels.", "path"_a);
  m.def("compare", &compare, "lamina compare's metrics (renderer/image/image_compare.h).", "reference"_a, "test"_a, "epsilon"_a);
  m.def("relative_luminance_difference", &relative_luminance, "The relative difference of luminance per pixel.", "reference"_a, "test"_a, "epsilon"_a);
  m.def("denoise", &denoise_image, "Open Image Denoise (renderer/image/denoise.h): image, library, version.", "colour"_a, "albedo"_a.none(), "normal"_a.none(), "threads"_a);
  m.attr("DEFAULT_GUARD_EPSILON") = kDefaultGuardEpsilon;
  // lamina render's --spectral (renderer/render/spectral_option.h): lamina.render's keyword, the
  // flag it stands for and its help.
  m.attr("SPECTRAL_OPTION") = nb::make_tuple(spectral_option_key(), kSpectralOption.flag, kSpectralOption.help);
}
