// lamina render: a glTF scene to a linear EXR (contracts.md, "lamina render").
#include <unistd.h>

#include <chrono>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "renderer/scene/camera.h"
#include "renderer/cli/commands.h"
#include "renderer/render/environment.h"
#include "renderer/image/image_io.h"
#include "renderer/render/integrator.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/layered_table.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/render/lights.h"
#include "renderer/util/progress.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/layered/subsurface_auto.h"

namespace lamina {
namespace {

constexpr const char* kVersion = "0.1.0";
// Limits that catch typos (an extra zero or three), not real renders.
constexpr int kMaxResolution = 16384;
constexpr int kMaxSpp = 1 << 20;
constexpr double kMaxPathSamples = 1e12;  // width x height x spp

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The output path must be creatable: its directory exists and is writable, and it is not a
// directory itself. Checked before rendering so a long render never ends in a failed write.
void check_writable(const std::string& path, const char* what) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw UsageError(std::string(what) + " '" + path + "' is a directory");
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) throw UsageError(std::string(what) + " '" + path + "': directory '" + dir.string() + "' does not exist");
  if (::access(dir.c_str(), W_OK) != 0) throw UsageError(std::string(what) + " '" + path + "': directory '" + dir.string() + "' is not writable");
}

std::string join_command_line(int argc, char** argv) {
  std::string s = "lamina";
  for (int i = 0; i < argc; ++i) s += std::string(" ") + argv[i];
  return s;
}

const CameraDesc& find_camera(const SceneDesc& scene, const std::string& name) {
  std::string names;
  for (const CameraDesc& c : scene.cameras) {
    if (c.name == name || c.node_name == name) return c;
    names += (names.empty() ? "" : ", ") + ("'" + c.name + "'");
  }
  throw UsageError(scene.path + ": no camera named '" + name + "' (cameras: " + (names.empty() ? "none" : names) + ")");
}

}  // namespace
}  // namespace lamina

int run_render(int argc, char** argv) {
  using namespace lamina;
  CLI::App app("Renders a glTF 2.0 scene (.gltf/.glb) to a linear RGB EXR.", "lamina render");
  std::string scene_path, out_path, camera_name, materials_path, env_value, png_path;
  RenderSettings settings;
  settings.width = 640;
  settings.height = 480;
  settings.spp = 16;
  std::string subsurface = "random-walk";
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;
  bool auto_mode = false;
  double tolerance = 0.0;
  app.add_option("scene", scene_path, "glTF 2.0 scene (.gltf or .glb)")->required();
  app.add_option("-o,--out", out_path, "output EXR (default: the scene's name with .exr, here)");
  app.add_option("--spp", settings.spp, "samples per pixel")->capture_default_str();
  app.add_option("--width", settings.width, "image width in pixels")->capture_default_str();
  app.add_option("--height", settings.height, "image height in pixels")->capture_default_str();
  app.add_option("--camera", camera_name, "camera name (default: the first; none: one framing the scene)");
  app.add_option("--materials", materials_path, "material map JSON: {\"glTF material name\": \"stack.json\", ...} (paths relative to the map)");
  app.add_option("--seed", settings.seed, "random seed")->capture_default_str();
  app.add_option("--threads", settings.threads, "worker threads (0: all cores)")->capture_default_str();
  app.add_option("--subsurface", subsurface,
                 "shading of layered materials: random-walk|first-order|table|lambert|auto")
      ->capture_default_str();
  CLI::Option* tolerance_opt = app.add_option(
      "--tolerance", tolerance, "with --subsurface auto: largest predicted relative error per material, in (0, 1]");
  app.add_option("--env", env_value, "environment: a number, R,G,B, or an equirectangular EXR/HDR (default black)");
  app.add_option("--max-depth", settings.max_depth, "maximum bounces")->capture_default_str();
  app.add_option("--png", png_path, "also write an sRGB PNG preview");
  std::string cache_dir;
  std::optional<WalkCache> cache;
  app.add_option("--cache", cache_dir,
                 "directory of walk results (tables, auto predictions, lambert albedos), reused when the stack, settings and lamina build match");
  std::vector<std::string> extra_meta;  // e.g. lamina batch's job hash
  app.add_option("--meta", extra_meta, "extra EXR header attribute KEY=VALUE (repeatable)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina render: %s\n", e.what());
    return 2;
  }

  try {
    if (settings.width < 1 || settings.width > kMaxResolution || settings.height < 1 || settings.height > kMaxResolution)
      throw UsageError("--width and --height must be between 1 and " + std::to_string(kMaxResolution));
    if (settings.spp < 1 || settings.spp > kMaxSpp)
      throw UsageError("--spp must be between 1 and " + std::to_string(kMaxSpp));
    if (static_cast<double>(settings.width) * settings.height * settings.spp > kMaxPathSamples)
      throw UsageError("--width x --height x --spp exceeds 1e12 paths");
    if (settings.max_depth < 0 || settings.max_depth > 100000) throw UsageError("--max-depth must be between 0 and 100000");
    if (settings.threads < 0 || settings.threads > 4096) throw UsageError("--threads must be between 0 and 4096");
    auto_mode = subsurface == "auto";
    if (!auto_mode && !parse_subsurface_mode(subsurface, &mode))
      throw UsageError("--subsurface '" + subsurface + "': expected random-walk, first-order, table, lambert or auto");
    if (tolerance_opt->count() > 0 && !auto_mode)
      throw UsageError("--tolerance is only meaningful with --subsurface auto");
    if (auto_mode && tolerance_opt->count() == 0) throw UsageError("--subsurface auto needs --tolerance E (e.g. 0.05)");
    if (auto_mode && !(tolerance > 0.0 && tolerance <= 1.0))
      throw UsageError("--tolerance must be a relative error in (0, 1]");
    for (const std::string& kv : extra_meta)
      if (kv.find('=') == std::string::npos || kv.front() == '=')
        throw UsageError("--meta '" + kv + "': expected KEY=VALUE");
    if (out_path.empty()) out_path = std::filesystem::path(scene_path).stem().string() + ".exr";
    check_writable(out_path, "output");
    if (!png_path.empty()) check_writable(png_path, "--png");
    if (!cache_dir.empty()) {
      try {
        cache.emplace(cache_dir);
      } catch (const std::runtime_error& e) {
        throw UsageError(std::string("--cache ") + e.what());
      }
    }
  } catch (const UsageError& e) {
    std::fprintf(stderr, "lamina render: %s\n", e.what());
    return 2;
  }

  try {
    EnvironmentMap env;
    if (!env_value.empty()) env = EnvironmentMap::from_argument(env_value);
    SceneDesc desc = load_gltf(scene_path);
    // Bound before the loader's warnings are printed, so that a binding error is one line.
    const LayeredBindings bindings = bind_layered_materials(desc, materials_path);
    for (const std::string& w : desc.warnings) std::fprintf(stderr, "lamina render: warning: %s: %s\n", scene_path.c_str(), w.c_str());
    const double aspect = static_cast<double>(settings.width) / settings.height;
    CameraDesc cam = camera_name.empty() ? (desc.cameras.empty() ? framing_camera(desc, aspect) : desc.cameras.front())
                                         : find_camera(desc, camera_name);
    std::vector<std::string> desc_names;
    for (std::size_t i = 0; i < bindings.by_material.size(); ++i) desc_names.push_back(desc.material(static_cast<int>(i)).name);
    const Scene scene(std::move(desc));
    const LightSet lights(scene, env);
    if (lights.empty())
      std::fprintf(stderr, "lamina render: warning: %s: no lights, no emissive surfaces and a black environment: the image is black\n",
                   scene_path.c_str());
    const Camera camera(cam, settings.width, settings.height);
    // --subsurface auto: a mode per material, predicted from its BSDF (renderer/layered/subsurface_auto.h).
    // Only materials that camera rays of a coarse grid hit are predicted.
    std::vector<AutoChoice> choices;
    std::vector<SubsurfaceMode> per_material;
    // Lambert albedos computed by an earlier run (the lambert mode's, auto's lambert model).
    if (cache)
      for (const auto& m : bindings.by_material)
        if (m) load_lambert_albedo(*cache, *m);
    if (auto_mode) {
      AutoSettings as;
      as.tolerance = tolerance;
      const std::vector<bool> visible = camera_visible_materials(scene, camera, settings.width, settings.height);
      choices = choose_subsurface_modes(bindings, as, &visible, cache ? &*cache : nullptr);
      per_material.assign(bindings.by_material.size(), SubsurfaceMode::RandomWalk);
      for (std::size_t i = 0; i < choices.size(); ++i)
        if (bindings.by_material[i]) {
          per_material[i] = choices[i].mode;
          std::printf("lamina render: auto: material %s (%s): %s [%s%.2f s]\n", desc_names[i].c_str(),
                      bindings.by_material[i]->source().c_str(), choices[i].reason.c_str(),
                      choices[i].cached ? "from the cache; predicted in " : "", choices[i].seconds);
        }
    }
    auto uses = [&](SubsurfaceMode m) {
      if (!auto_mode) return mode == m;
      for (std::size_t i = 0; i < per_material.size(); ++i)
        if (bindings.by_material[i] && per_material[i] == m) return true;
      return false;
    };
    std::unique_ptr<LayeredTables> tables;
    if (bindings.count() > 0 && uses(SubsurfaceMode::Table)) {
      std::vector<bool> only(bindings.by_material.size(), true);
      if (auto_mode)
        for (std::size_t i = 0; i < only.size(); ++i) only[i] = per_material[i] == SubsurfaceMode::Table;
      int tabulated = 0;
      for (std::size_t i = 0; i < only.size(); ++i) tabulated += only[i] && bindings.by_material[i] ? 1 : 0;
      tables = std::make_unique<LayeredTables>(bindings, TableSettings{}, only, cache ? &*cache : nullptr);
      std::printf("lamina render: table mode: BRDF/BTDF tables of %d layered material(s): %d built by the walk in %.2f s, %d loaded from %s (%.0f kB)\n",
                  tabulated, tables->built(), tables->build_seconds(), tables->loaded(),
                  cache ? cache->directory().c_str() : "no cache", tables->bytes() / 1024.0);
    }
    if (bindings.count() > 0 && !auto_mode && mode == SubsurfaceMode::Lambert) {
      // Computed before rendering so that the render's time is the render's.
      const auto t0 = std::chrono::steady_clock::now();
      for (const auto& m : bindings.by_material)
        if (m) {
          const Spectrum a = m->lambert_albedo(), se = m->lambert_albedo_stderr();
          std::printf("lamina render: lambert mode: %s: diffuse bihemispherical albedo %.4f %.4f %.4f (+- %.4f %.4f %.4f)\n",
                      m->source().c_str(), a[0], a[1], a[2], se[0], se[1], se[2]);
        }
      int from_cache = 0;
      for (const auto& m : bindings.by_material) from_cache += m && !m->lambert_albedo_computed() ? 1 : 0;
      std::printf("lamina render: lambert mode: albedos by the walk in %.2f s (%d from the cache)\n",
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), from_cache);
    }
    LayeredShading layered;
    layered.bindings = &bindings;
    layered.mode = mode;
    layered.per_material = per_material;
    layered.tables = tables.get();
    settings.layered = &layered;

    Progress progress("render", static_cast<std::uint64_t>(settings.width) * settings.height * settings.spp);
    RenderStats stats;
    const Image image = render_image(scene, lights, camera, settings, &stats,
                                     [&](std::uint64_t n) { progress.advance(n); });
    progress.finish();
    const double seconds = progress.elapsed_seconds();
    if (cache)
      for (const auto& m : bindings.by_material)
        if (m) store_lambert_albedo(*cache, *m);

    std::ostringstream sec;
    sec << seconds;
    Metadata meta = {
        {"lamina:version", kVersion},
        {"lamina:command", join_command_line(argc, argv)},
        {"lamina:scene", scene_path},
        {"lamina:camera", cam.name},
        {"lamina:spp", std::to_string(settings.spp)},
        {"lamina:seed", std::to_string(settings.seed)},
        {"lamina:max_depth", std::to_string(settings.max_depth)},
        {"lamina:env", env_value.empty() ? "0" : env_value},
        {"lamina:subsurface", subsurface},
        {"lamina:seconds", sec.str()},
        {"lamina:rays_closest", std::to_string(stats.rays.closest)},
        {"lamina:rays_camera", std::to_string(stats.rays.camera)},
        {"lamina:rays_shadow", std::to_string(stats.rays.shadow)},
        {"lamina:layered_materials", std::to_string(bindings.count())},
        {"lamina:scatter_events", std::to_string(stats.rays.scatter_events)},
        {"lamina:event_shadow_rays", std::to_string(stats.rays.event_shadow)},
    };
    if (auto_mode) {
      std::ostringstream tol;
      tol << tolerance;
      meta.emplace_back("lamina:tolerance", tol.str());
      for (std::size_t i = 0; i < choices.size(); ++i)
        if (bindings.by_material[i])
        {
          meta.emplace_back("lamina:auto:" + desc_names[i], choices[i].reason);
          // The same choice for programs (lamina batch's auto_choices column).
          meta.emplace_back("lamina:auto_mode:" + desc_names[i],
                            choices[i].visible ? subsurface_mode_name(choices[i].mode) : "lambert-hidden");
        }
    }
    for (const std::string& kv : extra_meta) {
      const std::size_t eq = kv.find('=');
      meta.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
    }
    write_exr(out_path, image, meta);
    if (!png_path.empty()) write_png(png_path, image);

    const double s = std::max(seconds, 1e-9);
    std::printf(
        "lamina render: %s -> %s: %dx%d, %d spp, %.2f s; rays: %.3g closest-hit (%.3g camera) = %.3g/s, %.3g shadow = "
        "%.3g/s; peak memory %.0f MB\n",
        scene_path.c_str(), out_path.c_str(), settings.width, settings.height, settings.spp, seconds,
        static_cast<double>(stats.rays.closest), static_cast<double>(stats.rays.camera), stats.rays.closest / s,
        static_cast<double>(stats.rays.shadow), stats.rays.shadow / s, peak_memory_bytes() / 1048576.0);
    if (bindings.count() > 0)
      std::printf("lamina render: layered (%s): %d material(s), %.3g scattering events, %.3g shadow rays from events\n",
                  subsurface.c_str(), bindings.count(), static_cast<double>(stats.rays.scatter_events),
                  static_cast<double>(stats.rays.event_shadow));
    if (stats.invalid_samples > 0)
      std::fprintf(stderr, "lamina render: warning: %llu non-finite path samples dropped\n",
                   static_cast<unsigned long long>(stats.invalid_samples));
    return 0;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "lamina render: %s\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina render: %s\n", e.what());
  }
  return 1;
}
