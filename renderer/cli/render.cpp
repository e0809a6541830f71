// lamina render: a glTF scene to a linear EXR (docs/contracts.md, "lamina render").
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "renderer/cli/commands.h"
#include "renderer/cli/options.h"
#include "renderer/cli/outputs.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/render/render_job.h"
#include "renderer/render/render_request_check.h"
#include "renderer/render/spectral_option.h"
#include "renderer/render/walk_option_table.h"
#include "renderer/util/progress.h"
#include "renderer/util/string_format.h"

namespace lamina {
namespace {

// Limits that catch typos (an extra zero or three), not real renders.
constexpr int kMaxResolution = 16384;
constexpr int kMaxSpp = 1 << 20;
constexpr int kMaxDepth = 100000;
constexpr int kMaxThreads = 4096;

// The image in memory (docs/contracts.md, "lamina render"): the film is the float image itself,
// 3 floats a pixel (a pixel's samples are summed in registers and stored once), and --png adds an
// 8-bit copy, 3 bytes a pixel. Together at most 4 GiB, and at most half of the memory the
// process may use (the rest is for the scene, its BVH, the tables and the libraries), so that
// an image that cannot be held is refused now and not by std::bad_alloc after loading.
constexpr double kMaxImageBytes = 4.0 * 1024 * 1024 * 1024;

using cli::UsageError;

// The memory this process may use, and what bounds it: physical memory, RLIMIT_AS, RLIMIT_DATA
// and the cgroup's memory.max (cgroup v2), whichever is smallest.
double memory_limit_bytes(std::string* what) {
  double limit = std::numeric_limits<double>::infinity();
  auto take = [&](double bytes, const char* name) {
    if (bytes > 0.0 && bytes < limit) {
      limit = bytes;
      *what = name;
    }
  };
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) take(static_cast<double>(pages) * static_cast<double>(page), "physical memory");
  struct rlimit rl;
  if (::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) take(static_cast<double>(rl.rlim_cur), "RLIMIT_AS");
  if (::getrlimit(RLIMIT_DATA, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
    take(static_cast<double>(rl.rlim_cur), "RLIMIT_DATA");
  std::ifstream cgroup("/sys/fs/cgroup/memory.max");
  double bytes = 0.0;
  if (cgroup >> bytes) take(bytes, "cgroup memory.max");  // "max" (no limit) does not read
  return limit;
}

std::string gib(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

void check_image_memory(const RenderSettings& s, bool png) {
  // Rendering in rounds (adaptive sampling, time limits, previews) keeps per pixel its running
  // sums (film.cpp's PixelSums, 120 bytes) and a planned count, adaptive sampling a pilot
  // mean and variance; the counts are a 4th EXR channel (interleaved with RGB on writing). AOVs
  // are 10 floats a pixel, and twice that while interleaved for the EXR.
  const bool rounds = s.noise_threshold > 0.0 || s.time_limit > 0.0 || s.preview_every > 0.0;
  const bool counts = s.noise_threshold > 0.0 || s.time_limit > 0.0;
  const double aov_floats = 3.0 * s.aovs.albedo + 3.0 * s.aovs.normal + 1.0 * s.aovs.depth + 3.0 * s.aovs.variance;
  const double per_pixel = 3 * sizeof(float) + (png ? 3 : 0) + (rounds ? 120 + 4 : 0) + (counts ? 2 * 8 + 2 * 4 : 0) +
                           2 * aov_floats * sizeof(float);
  const int w = s.crop.empty() ? s.width : s.crop.x1 - s.crop.x0, h = s.crop.empty() ? s.height : s.crop.y1 - s.crop.y0;
  const double bytes = static_cast<double>(w) * h * per_pixel;
  std::string bound;
  const double available = memory_limit_bytes(&bound);
  const std::string size = std::to_string(w) + "x" + std::to_string(h) + " image" + (png ? " with --png" : "") +
                           (counts ? " with per-pixel sample counts" : "");
  if (bytes > kMaxImageBytes)
    throw UsageError("--width x --height: a " + size + " needs " + gib(bytes) + ", above the limit of " + gib(kMaxImageBytes));
  if (bytes > 0.5 * available)
    throw UsageError("--width x --height: a " + size + " needs " + gib(bytes) + ", more than half of the " + gib(available) +
                     " this process may use (" + bound + ")");
}

// The walk's options, one CLI11 option per row of kWalkOptionTable: integers and reals bound to
// their member, each switch to its word in (*switches)[row] (set_walk_switch reads it after
// parsing), each with the default shown.
void add_walk_options(CLI::App& app, RandomWalkOptions* walk, std::vector<std::string>* switches) {
  for (std::size_t i = 0; i < kWalkOptionTable.size(); ++i) {
    const WalkOptionSpec& spec = kWalkOptionTable[i];
    switch (spec.kind) {
      case WalkOptionSpec::Kind::Switch:
        (*switches)[i] = walk_option_text(spec, *walk);
        app.add_option(spec.flag, (*switches)[i], spec.help)
            ->capture_default_str()
            ->check(CLI::IsMember({std::string(spec.on_word), std::string(spec.off_word)}));
        break;
      case WalkOptionSpec::Kind::Integer:
        app.add_option(spec.flag, walk->*spec.integer_member, spec.help)
            ->capture_default_str()
            ->check(cli::integer(static_cast<long long>(spec.lo), static_cast<long long>(spec.hi)));
        break;
      case WalkOptionSpec::Kind::Real:
        app.add_option(spec.flag, walk->*spec.real_member, spec.help)
            ->capture_default_str()
            ->check(cli::real(spec.lo, spec.hi, spec.lo_open, spec.hi_open));
        break;
    }
  }
}

// -o chooses the format by its extension, and the render writes OpenEXR only: a .png (or any
// other) name would hold an EXR under the wrong name, so it is refused, and the display PNG has
// its own option. (Writing only a PNG at -o is not one change: the render, its previews and
// lamina batch all write the EXR at -o.) For a .png the message gives the command that works.
void check_out_extension(const std::string& out_path) {
  const std::filesystem::path path(out_path);
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".exr") return;
  if (ext == ".png")
    throw UsageError("--out '" + out_path + "': lamina render writes OpenEXR at --out; use --png '" + out_path +
                     "' for the display PNG, with an EXR beside it: -o '" + std::filesystem::path(path).replace_extension(".exr").string() +
                     "' --png '" + out_path + "'");
  throw UsageError("--out '" + out_path + "': " + (ext.empty() ? "no extension" : "'" + ext + "' is not written") +
                   "; lamina render writes OpenEXR (.exr), and a display PNG beside it with --png FILE.png");
}

std::string join_command_line(int argc, char** argv) {
  std::string s = "lamina";
  for (int i = 0; i < argc; ++i) s += std::string(" ") + argv[i];
  return s;
}

}  // namespace

RenderLog render_log() {
  RenderLog log;
  log.info = [](const std::string& line) { std::printf("lamina render: %s\n", line.c_str()); };
  log.warning = [](const std::string& line) { std::fprintf(stderr, "lamina render: warning: %s\n", line.c_str()); };
  return log;
}

// The samples per pixel the image holds: --spp, or with adaptive sampling or a time limit their
// mean over the pixels (the next summary line gives the least and the most).
static std::string spp_taken(const RenderResult& r, const RenderSettings& settings) {
  if (r.stats.pixel_samples.empty()) return std::to_string(settings.spp);
  return string_printf("mean %.1f", mean_spp(r.stats, settings));
}

void print_render_summary(const RenderRequest& request, const RenderResult& r) {
  const RenderSettings& settings = request.settings;
  const RayCounters& rays = r.stats.rays;
  const double s = std::max(r.seconds, 1e-9);
  std::printf(
      "lamina render: %s -> %s: %dx%d, %s spp, %.2f s; rays: %.3g closest-hit (%.3g camera) = %.3g/s, %.3g shadow = "
      "%.3g/s; peak memory %.0f MB\n",
      request.scene_path.c_str(), request.out_path.c_str(), settings.width, settings.height, spp_taken(r, settings).c_str(),
      r.seconds,
      static_cast<double>(rays.closest), static_cast<double>(rays.camera), rays.closest / s,
      static_cast<double>(rays.shadow), rays.shadow / s, peak_memory_bytes() / 1048576.0);
  if (r.layered_materials > 0)
    std::printf("lamina render: layered (%s): %d material(s), %.3g scattering events\n", request.subsurface.name().c_str(),
                r.layered_materials, static_cast<double>(rays.scatter_events));
  if (!r.stats.pixel_samples.empty()) {
    std::uint32_t lo = r.stats.pixel_samples.front(), hi = lo;
    for (std::uint32_t n : r.stats.pixel_samples) {
      lo = std::min(lo, n);
      hi = std::max(hi, n);
    }
    std::printf("lamina render: samples per pixel: mean %.1f (min %u, max %u)%s%s%s\n", mean_spp(r.stats, settings), lo,
                hi,
                settings.noise_threshold > 0.0
                    ? string_printf("; noise threshold %g: %.0f%% of pixels planned below %d spp, %.3g of the samples in the pilot",
                                    settings.noise_threshold, 100.0 * r.stats.converged_fraction, settings.spp,
                                    static_cast<double>(r.stats.pilot_samples))
                          .c_str()
                    : "",
                settings.time_limit > 0.0 ? string_printf("; time limit %g s", settings.time_limit).c_str() : "",
                r.stats.time_limit_reached ? " (reached)" : "");
  }
  if (settings.clamp > 0.0)
    std::printf("lamina render: --clamp %g (biased): %llu of the path samples clamped\n", settings.clamp,
                static_cast<unsigned long long>(r.stats.clamped_samples));
  if (r.stats.invalid_samples > 0)
    std::fprintf(stderr, "lamina render: warning: %llu non-finite path samples dropped\n",
                 static_cast<unsigned long long>(r.stats.invalid_samples));
}

}  // namespace lamina

int run_render(int argc, char** argv) {
  using namespace lamina;
  CLI::App app("Renders a glTF 2.0 scene (.gltf/.glb) to a linear RGB EXR.", "lamina render");
  std::string scene_path, out_path, camera_name, materials_path, env_value, png_path;
  RenderSettings settings;
  settings.width = 640;
  settings.height = 480;
  settings.spp = 16;
  std::string subsurface = subsurface_mode_name(SubsurfaceMode::RandomWalk);
  SubsurfaceChoice choice;
  double tolerance = 0.0;
  app.add_option("scene", scene_path, "glTF 2.0 scene (.gltf or .glb)")->required();
  app.add_option("-o,--out", out_path, "output EXR, named .exr (default: the scene's name with .exr, here)");
  app.add_option("--spp", settings.spp, "samples per pixel")->capture_default_str()->check(cli::integer(1, kMaxSpp));
  app.add_option("--width", settings.width, "image width in pixels")
      ->capture_default_str()
      ->check(cli::integer(1, kMaxResolution));
  app.add_option("--height", settings.height, "image height in pixels")
      ->capture_default_str()
      ->check(cli::integer(1, kMaxResolution));
  app.add_option("--camera", camera_name, "camera name (default: the first; none: one framing the scene)");
  std::vector<std::string> stack_args;
  app.add_option(kStackFlag, stack_args, kStackHelp);
  app.add_option("--materials", materials_path, "material map JSON: {\"glTF material name\": \"stack.json\", ...} (paths relative to the map)");
  app.add_option("--seed", settings.seed, "random seed")->capture_default_str()->check(cli::seed());
  app.add_option("--threads", settings.threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(cli::integer(0, kMaxThreads));
  app.add_option("--subsurface", subsurface,
                 "shading of layered materials: " + subsurface_mode_names("|") + "|" + kAutoSubsurfaceName)
      ->capture_default_str();
  app.add_option("--tolerance", tolerance,
                 "with --subsurface auto: largest predicted relative error per material, in (0, 1]")
      ->check(cli::real(0.0, 1.0, true, false));
  app.add_option("--env", env_value, "environment: a number, R,G,B, or an equirectangular EXR/HDR (default black)")
      ->check(cli::environment());
  app.add_option("--max-depth", settings.max_depth, "maximum bounces")->capture_default_str()->check(cli::integer(0, kMaxDepth));
  app.add_option("--png", png_path, "also write an sRGB PNG preview (tone mapped: --exposure, --tone-curve)");
  ToneMap tone_map;
  app.add_option("--exposure", tone_map.exposure, "PNG only: stops of exposure before the tone curve (the EXR stays linear)")
      ->capture_default_str()
      ->check(cli::real(-20.0, 20.0));
  std::string tone_curve = tone_curve_name(tone_map.curve);
  app.add_option("--tone-curve", tone_curve,
                 "PNG only: filmic (ACES reference rendering + sRGB output, highlights roll off) or clamp (clipped at 1)")
      ->capture_default_str()
      ->check(CLI::IsMember({"filmic", "clamp"}));
  // The walk's options, from their table (renderer/render/walk_option_table.h).
  RandomWalkOptions walk;
  std::vector<std::string> walk_switches(kWalkOptionTable.size());
  add_walk_options(app, &walk, &walk_switches);
  app.add_option("--noise-threshold", settings.noise_threshold,
                 "adaptive sampling: target relative standard error of each pixel's luminance, in (0, 1) "
                 "(--spp is then the most samples a pixel gets)")
      ->check(cli::real(0.0, 1.0, true, true));
  app.add_option("--pilot-spp", settings.pilot_spp,
                 "with --noise-threshold: samples per pixel of the pilot pass from which each pixel's neighbours are planned")
      ->capture_default_str()
      ->check(cli::integer(1, kMaxSpp));
  app.add_option("--time-limit", settings.time_limit,
                 "stop the render loop after this many seconds (rounds of 8 samples per pixel; the first always completes)")
      ->check(cli::real(0.0, 1e9, true, false));
  std::string table_method = "adding-doubling";
  app.add_option("--table-method", table_method,
                 "with --subsurface table or auto: build the tables by adding-doubling (noise-free; the walk where it "
                 "cannot resolve a lobe) or by the walk")
      ->capture_default_str()
      ->check(CLI::IsMember({"adding-doubling", "walk"}));
  std::string cache_dir;
  app.add_option("--cache", cache_dir,
                 "directory of walk results (tables, auto predictions, lambert albedos), reused when the stack, settings and lamina build match");
  std::string aov_list = "none";
  app.add_option("--aovs", aov_list,
                 "feature images written as more EXR channels: a comma-separated list of albedo, normal, depth, variance, "
                 "or all (albedo.R/G/B, N.X/Y/Z, Z, variance.R/G/B)")
      ->capture_default_str();
  std::vector<int> crop;
  app.add_option("--crop", crop,
                 "render only pixels X0 <= x < X1, Y0 <= y < Y1 of the image (X0,Y0,X1,Y1), each exactly as in the full image")
      ->delimiter(',')
      ->expected(4)
      ->check(cli::integer(0, kMaxResolution));
  app.add_option("--preview-every", settings.preview_every,
                 "write the image so far to the outputs every this many seconds (between rounds of 8 samples per pixel)")
      ->check(cli::real(0.0, 1e9, true, false));
  app.add_option("--clamp", settings.clamp,
                 "BIASED: scale down any path sample whose largest channel exceeds this radiance (fireflies); "
                 "the light removed is lost, and the count of clamped samples is printed")
      ->check(cli::real(0.0, 1e30, true, false));
  std::vector<StackAssignment> stacks;
  std::vector<std::string> extra_meta;  // e.g. lamina batch's job hash
  app.add_flag(kSpectralOption.flag, settings.spectral, kSpectralOption.help);
  app.add_option("--meta", extra_meta, "extra EXR header attribute KEY=VALUE (repeatable)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina render: %s\n", cli::parse_error_line(e).c_str());
    return 2;
  }

  RenderRequest request;
  try {
    // Each number is in its range (the validators above); the combinations are the library's
    // (renderer/render/render_request_check.h), checked on the request below.
    std::string bad_aov;
    if (!parse_aov_names(aov_list, &settings.aovs, &bad_aov))
      throw UsageError("--aovs '" + aov_list + "': unknown AOV '" + bad_aov + "' (expected albedo, normal, depth, variance, all or none)");
    if (!crop.empty()) settings.crop = PixelRegion{crop[0], crop[1], crop[2], crop[3]};
    if (!parse_subsurface_choice(subsurface, &choice))
      throw UsageError("--subsurface '" + subsurface + "': expected " + subsurface_choice_expected());
    choice.tolerance = choice.automatic ? tolerance : 0.0;
    for (const CLI::Option* option : app.get_options())
      if (option->count() > 0) request.given.push_back(option->get_name());
    request.png_path = png_path;
    request.subsurface = choice;
    request.settings = settings;
    check_render_request(request);
    check_image_memory(settings, !png_path.empty());
    for (const std::string& text : stack_args) {
      StackAssignment a;
      std::string why;
      if (!parse_stack_assignment(text, &a, &why)) throw UsageError(std::string(kStackFlag) + " '" + text + "': " + why);
      stacks.push_back(a);
    }
    for (const std::string& kv : extra_meta)
      if (kv.find('=') == std::string::npos || kv.front() == '=')
        throw UsageError("--meta '" + kv + "': expected KEY=VALUE");
    if (out_path.empty()) out_path = std::filesystem::path(scene_path).stem().string() + ".exr";
    const std::vector<cli::OutputPath> output_paths = {{"--out", out_path}, {"--png", png_path}};
    cli::check_output_paths(output_paths);
    // An output that is an input is the graver mistake: said before the extension.
    cli::check_outputs_not_inputs(output_paths, {{"the scene", scene_path}, {"--materials", materials_path}, {"--env", env_value}});
    check_out_extension(out_path);
    if (!cache_dir.empty()) {
      try {
        WalkCache check(cache_dir);  // created and writable, or a usage error now
      } catch (const std::runtime_error& e) {
        throw UsageError(std::string("--cache ") + e.what());
      }
    }
  } catch (const std::runtime_error& e) {  // UsageError, cli::OutputPathError
    std::fprintf(stderr, "lamina render: %s\n", cli::one_line(e.what()).c_str());
    return 2;
  } catch (const RenderRequestError& e) {
    std::fprintf(stderr, "lamina render: %s\n", e.what());
    return 2;
  }

  request.scene_path = scene_path;
  request.out_path = out_path;
  parse_tone_curve(tone_curve, &tone_map.curve);  // one of the two names (checked above)
  request.tone_map = tone_map;
  request.camera_name = camera_name;
  request.materials_map_path = materials_path;
  request.stacks = stacks;
  request.env = env_value;
  request.cache_dir = cache_dir;
  request.table_method = table_method == "walk" ? TableSettings::Method::MonteCarlo : TableSettings::Method::AddingDoubling;
  for (std::size_t i = 0; i < kWalkOptionTable.size(); ++i)
    if (kWalkOptionTable[i].kind == WalkOptionSpec::Kind::Switch) set_walk_switch(kWalkOptionTable[i], walk_switches[i], &walk);
  request.walk = walk;
  request.command_line = join_command_line(argc, argv);
  for (const std::string& kv : extra_meta) {
    const std::size_t eq = kv.find('=');
    request.extra_metadata.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
  }
  try {
    const RenderResult r = render_job(request, render_log());
    print_render_summary(request, r);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina render: %s\n", cli::one_line(e.what()).c_str());
  }
  return 1;
}
