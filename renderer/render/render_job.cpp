#include "renderer/render/render_job.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "renderer/layered/layered_shading.h"
#include "renderer/layered/subsurface_auto.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/layered/wavelength_stack.h"
#include "renderer/render/environment.h"
#include "renderer/render/lights.h"
#include "renderer/render/render_metadata.h"
#include "renderer/render/render_request_check.h"
#include "renderer/render/shading_preparation.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/util/atomic_file.h"
#include "renderer/util/paths.h"
#include "renderer/util/progress.h"
#include "renderer/util/string_format.h"

namespace lamina {

// Mean samples per pixel in the image (adaptive sampling and time limits vary it).
double mean_spp(const RenderStats& stats, const RenderSettings& settings) {
  if (stats.pixel_samples.empty()) return settings.spp;
  double sum = 0.0;
  for (std::uint32_t n : stats.pixel_samples) sum += n;
  return sum / static_cast<double>(stats.pixel_samples.size());
}
std::string aov_names(const AovSelection& aovs) {
  std::string names;
  auto add = [&](bool on, const char* name) {
    if (on) names += (names.empty() ? "" : ",") + std::string(name);
  };
  add(aovs.albedo, "albedo");
  add(aovs.normal, "normal");
  add(aovs.depth, "depth");
  add(aovs.variance, "variance");
  return names.empty() ? "none" : names;
}

bool parse_aov_names(const std::string& list, AovSelection* aovs, std::string* bad) {
  AovSelection chosen;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    const std::string name = list.substr(start, comma - start);
    if (name == "albedo") chosen.albedo = true;
    else if (name == "normal") chosen.normal = true;
    else if (name == "depth") chosen.depth = true;
    else if (name == "variance") chosen.variance = true;
    else if (name == "all") chosen = AovSelection{true, true, true, true};
    else if (name != "none" || list != "none") {
      *bad = name;
      return false;
    }
    start = comma + 1;
  }
  *aovs = chosen;
  return true;
}

namespace {

void say(const std::function<void(const std::string&)>& to, const std::string& line) {
  if (to) to(line);
}

// The first step: the environment, the scene, its layered materials' bindings, the camera and
// the lights. Filled in place: the lights point into the scene and the environment.
struct LoadedScene {
  EnvironmentMap env;
  LayeredBindings bindings;
  std::vector<std::string> material_names;  // glTF material names, by slot
  CameraDesc camera_desc;
  std::unique_ptr<Scene> scene;
  std::unique_ptr<LightSet> lights;
  std::unique_ptr<Camera> camera;
};

// The command line checked the files it names; those the scene pulls in are known only once it
// is read: the buffers and images the glTF names (resolved as the loader found them), the stack
// files of its materials and the maps their parameters are bound to. No output may be one of
// them, under any name (renderer/util/paths.h's same_file).
void check_outputs_not_scene_inputs(const RenderRequest& request, const SceneDesc& desc, const LayeredBindings& bindings) {
  std::vector<std::pair<std::string, std::string>> inputs;  // how the message names it, the file
  for (const std::string& f : desc.files_read) inputs.emplace_back("a file of the scene '" + request.scene_path + "'", f);
  for (const auto& m : bindings.by_material) {
    if (!m) continue;
    inputs.emplace_back("the stack file", m->source());
    if (m->bindings())
      for (const std::string& f : m->bindings()->map_files()) inputs.emplace_back("a parameter map of the stack '" + m->source() + "'", f);
  }
  for (const std::string& output : {request.out_path, request.png_path})
    for (const auto& [what, path] : inputs)
      if (!output.empty() && same_file(output, path))
        throw std::runtime_error("the output '" + output + "' is " + what + " '" + path + "': an input is never overwritten");
}

void load_scene(const RenderRequest& request, const RenderLog& log, LoadedScene* out) {
  const RenderSettings& settings = request.settings;
  if (!request.env.empty()) out->env = EnvironmentMap::from_argument(request.env);
  SceneDesc desc = load_gltf(request.scene_path);
  adopt_meshes_without_material(request.stacks, &desc);
  // Bound before the loader's warnings are printed, so that a binding error is one line.
  out->bindings = bind_layered_materials(desc, request.materials_map_path, request.inline_stacks, request.stacks,
                                         request.settings.spectral);
  check_outputs_not_scene_inputs(request, desc, out->bindings);
  for (const std::string& w : desc.warnings) say(log.warning, request.scene_path + ": " + w);
  const double aspect = static_cast<double>(settings.width) / settings.height;
  out->camera_desc = request.camera_name.empty()
                         ? (desc.cameras.empty() ? framing_camera(desc, aspect) : desc.cameras.front())
                         : find_camera(desc, request.camera_name);
  // The image's aspect is --width/--height (yfov spans the height); a camera's own aspectRatio
  // that differs does not act, and the user is told once.
  if (const double a = out->camera_desc.aspect_ratio; a > 0.0 && std::abs(a / aspect - 1.0) > 1e-3)
    say(log.warning, string_printf("%s: camera '%s': aspectRatio %g is not used: the image's aspect is --width/--height = %g "
                                   "(yfov spans the height; give a width and height in the ratio %g to match the file)",
                                   request.scene_path.c_str(), out->camera_desc.name.c_str(), a, aspect, a));
  for (std::size_t i = 0; i < out->bindings.by_material.size(); ++i)
    out->material_names.push_back(desc.material(static_cast<int>(i)).name);
  out->scene = std::make_unique<Scene>(std::move(desc));
  out->lights = std::make_unique<LightSet>(*out->scene, out->env);
  if (out->lights->empty())
    say(log.warning, request.scene_path + ": no lights, no emissive surfaces and a black environment: the image is black");
  out->camera = std::make_unique<Camera>(out->camera_desc, settings.width, settings.height);
}

// What auto chose, per layered material, as the header and lamina batch read it.
std::vector<MaterialModeChoice> mode_choices(const LoadedScene& loaded, const std::vector<AutoChoice>& choices) {
  std::vector<MaterialModeChoice> out;
  for (std::size_t i = 0; i < choices.size(); ++i)
    if (loaded.bindings.by_material[i])
      out.push_back({loaded.material_names[i], choices[i].visible ? subsurface_mode_name(choices[i].mode) : kHiddenAutoModeName,
                     choices[i].reason});
  return out;
}

// The pixels rendered, of the crop if any.
PixelRegion rendered_region(const RenderSettings& settings) {
  return settings.crop.empty() ? PixelRegion{0, 0, settings.width, settings.height} : settings.crop;
}
std::uint64_t pixel_count(const PixelRegion& r) { return static_cast<std::uint64_t>(r.x1 - r.x0) * (r.y1 - r.y0); }
DataWindow data_window(const RenderSettings& settings) {
  const PixelRegion region = rendered_region(settings);
  return settings.crop.empty() ? DataWindow{} : DataWindow{region.x0, region.y0, settings.width, settings.height};
}

// The third step: the image (and its AOVs), with a progress line and, with --preview-every, the
// image so far written to the outputs (each atomically), marked as a preview in the header; the
// final image replaces them in the end.
Image render(const RenderRequest& request, const LoadedScene& loaded, const LayeredShading& layered, RenderResult* result,
             RenderAovs* aovs, bool* previews_written) {
  RenderSettings settings = request.settings;
  settings.layered = &layered;
  const std::uint64_t pixels = pixel_count(rendered_region(settings));
  // At most spp samples a pixel (the adaptive pilot's are among them); the adaptive plan then
  // sets the total it chose, and a time limit caps the ETA (docs/rendering.md, "Progress").
  const std::uint64_t planned = pixels * static_cast<std::uint64_t>(settings.spp);
  // The terminal's bar, unless the caller follows the progress itself.
  std::optional<Progress> progress;
  if (!request.on_progress) {
    progress.emplace("render", planned);
    if (settings.time_limit > 0.0)
      progress->set_deadline(settings.time_limit, pixels * static_cast<std::uint64_t>(first_round_samples(settings)));
  }
  std::atomic<std::uint64_t> done{0}, total{planned};
  const auto start = std::chrono::steady_clock::now();
  RenderProgress on_progress;
  on_progress.cancel = request.cancel;
  on_progress.advance = [&](std::uint64_t n) {
    if (progress) progress->advance(n);
    else request.on_progress(done += n, total.load());
  };
  on_progress.planned = [&](std::uint64_t new_total, double converged) {
    total = new_total;
    if (!progress) return;
    progress->set_total(new_total);
    progress->set_note(string_printf("adaptive: %.0f%% of pixels converge below %d spp", 100.0 * converged, settings.spp));
  };
  on_progress.preview = [&](const Image& so_far, std::uint64_t samples) {
    if (!request.write_files) return;
    Metadata preview_meta = identity_metadata({request, *result});
    preview_meta.emplace_back("lamina:preview", string_printf("%.6g", static_cast<double>(samples) / static_cast<double>(pixels)));
    write_exr(request.out_path, so_far, preview_meta, {}, data_window(settings));
    if (!request.png_path.empty()) write_png(request.png_path, tone_mapped(so_far, request.tone_map));
    *previews_written = true;
  };
  Image image = render_image(*loaded.scene, *loaded.lights, *loaded.camera, settings, &result->stats, on_progress, aovs);
  if (progress) {
    progress->finish();
    result->seconds = progress->elapsed_seconds();
  } else {
    result->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return image;
}

// The AOVs as extra EXR channels, under the names compositors and denoisers look for
// (docs/contracts.md, "AOVs"), after the per-pixel sample counts if any.
std::vector<ExtraChannel> extra_channels(const RenderStats& stats, const RenderAovs& aovs, std::uint64_t pixels) {
  std::vector<ExtraChannel> extra;
  if (!stats.pixel_samples.empty()) {
    ExtraChannel spp{"spp", {}};
    spp.values.assign(stats.pixel_samples.begin(), stats.pixel_samples.end());
    extra.push_back(std::move(spp));
  }
  auto add_rgb = [&](const Image& aov, const char* layer, const char* const names[3]) {
    if (aov.rgb.empty()) return;
    for (int c = 0; c < 3; ++c) {
      ExtraChannel channel{std::string(layer) + "." + names[c], std::vector<float>(pixels)};
      for (std::size_t i = 0; i < pixels; ++i) channel.values[i] = aov.rgb[i * 3 + static_cast<std::size_t>(c)];
      extra.push_back(std::move(channel));
    }
  };
  static const char* const kRgb[3] = {"R", "G", "B"};
  static const char* const kXyz[3] = {"X", "Y", "Z"};
  add_rgb(aovs.albedo, "albedo", kRgb);
  add_rgb(aovs.normal, "N", kXyz);
  if (!aovs.depth.empty()) extra.push_back({"Z", aovs.depth});
  add_rgb(aovs.variance, "variance", kRgb);
  return extra;
}

// The outputs all or none: each is written to a temporary beside it (renderer/util/
// atomic_file.h), and only when both are written are they renamed into place. A failed write
// removes the temporaries (the previous files stay); a failed rename of the PNG removes the
// EXR just renamed. Errors name the output, not its temporary.
class StagedOutputs {
 public:
  template <class Write>
  void stage(const std::string& path, Write&& write) {
    staged_.push_back({temporary_path(path), path});
    try {
      write(staged_.back().tmp);
    } catch (const std::exception& e) {
      for (const Staged& s : staged_) std::remove(s.tmp.c_str());
      std::string message = e.what();
      const std::string& tmp = staged_.back().tmp;
      for (std::size_t at = message.find(tmp); at != std::string::npos; at = message.find(tmp, at + path.size()))
        message.replace(at, tmp.size(), path);
      throw ImageIoError(message);
    }
  }
  void commit() {
    for (std::size_t i = 0; i < staged_.size(); ++i) {
      try {
        commit_temporary(staged_[i].tmp, staged_[i].path);  // removes its temporary on failure
      } catch (const AtomicWriteError&) {
        for (std::size_t j = 0; j < i; ++j) std::remove(staged_[j].path.c_str());
        for (std::size_t j = i + 1; j < staged_.size(); ++j) std::remove(staged_[j].tmp.c_str());
        throw;
      }
    }
  }

 private:
  struct Staged {
    std::string tmp, path;
  };
  std::vector<Staged> staged_;
};

// The fourth step: the EXR (with its header and extra channels) and the PNG.
void write_outputs(const RenderRequest& request, const Image& image, const Metadata& meta, const std::vector<ExtraChannel>& extra) {
  const DataWindow window = data_window(request.settings);
  StagedOutputs outputs;
  outputs.stage(request.out_path, [&](const std::string& tmp) { write_exr(tmp, image, meta, extra, window); });
  if (!request.png_path.empty())
    outputs.stage(request.png_path, [&](const std::string& tmp) { write_png(tmp, tone_mapped(image, request.tone_map)); });
  outputs.commit();
}

// A render that fails after writing previews removes them: the previous files are already
// replaced, so the outputs hold nothing rather than an unfinished image (docs/contracts.md,
// "Outputs"), and the message says so. Only regular files are removed.
[[noreturn]] void fail_after_previews(const RenderRequest& request, const std::exception& e) {
  std::string removed;
  for (const std::string& path : {request.out_path, request.png_path}) {
    std::error_code ec;
    if (path.empty() || !std::filesystem::is_regular_file(path, ec)) continue;
    std::filesystem::remove(path, ec);
    removed += (removed.empty() ? "'" : " and '") + path + "'";
  }
  throw std::runtime_error(std::string(e.what()) + (removed.empty() ? std::string("")
                                                                    : "; the previews written during the render were removed: nothing is left at " + removed));
}

}  // namespace

RenderResult render_job(const RenderRequest& request, const RenderLog& log) {
  check_render_request(request);
  std::optional<WalkCache> cache;
  if (!request.cache_dir.empty()) cache.emplace(request.cache_dir);
  LoadedScene loaded;
  load_scene(request, log, &loaded);
  check_table_method(request, loaded.bindings, loaded.material_names);
  // The spectral mode's chromophore layers, read (and what it cannot render refused) before the
  // shading is prepared.
  std::vector<std::shared_ptr<const SpectralStack>> spectral;
  if (request.settings.spectral) spectral = spectral_stacks(loaded.bindings);

  ShadingInputs inputs;
  inputs.bindings = &loaded.bindings;
  inputs.material_names = &loaded.material_names;
  inputs.scene = loaded.scene.get();
  inputs.camera = loaded.camera.get();
  inputs.width = request.settings.width;
  inputs.height = request.settings.height;
  inputs.subsurface = request.subsurface;
  inputs.table_method = request.table_method;
  inputs.walk = request.walk;
  inputs.cache = cache ? &*cache : nullptr;
  if (request.settings.spectral) inputs.spectral = &spectral;
  PreparedShading shading;
  prepare_shading(inputs, log, &shading);
  shading.layered.spectral = std::move(spectral);

  RenderResult result;
  result.camera = loaded.camera_desc.name;
  result.layered_materials = loaded.bindings.count();
  RenderAovs aovs;
  bool previews_written = false;
  try {
    Image image = render(request, loaded, shading.layered, &result, &aovs, &previews_written);
    if (cache)
      for (const auto& m : loaded.bindings.by_material)
        if (m) store_lambert_albedo(*cache, *m);

    if (request.subsurface.automatic) result.auto_choices = mode_choices(loaded, shading.choices);
    Metadata meta = render_metadata({request, result}, shading.similarity_bias, shading.ignored);
    std::vector<ExtraChannel> channels = extra_channels(result.stats, aovs, pixel_count(rendered_region(request.settings)));
    if (request.write_files) write_outputs(request, image, meta, channels);
    result.metadata = std::move(meta);
    result.image = std::move(image);
    result.channels = std::move(channels);
    result.window = data_window(request.settings);
  } catch (const std::exception& e) {
    if (previews_written) fail_after_previews(request, e);
    throw;
  }
  return result;
}

}  // namespace lamina
