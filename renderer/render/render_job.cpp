#include "renderer/render/render_job.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "materials/tables/albedo.h"
#include "materials/walk/random_walk.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/subsurface_auto.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/render/environment.h"
#include "renderer/render/lights.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/camera_visibility.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/util/atomic_file.h"
#include "renderer/util/progress.h"
#include "renderer/util/string_format.h"
#include "renderer/util/version.h"

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

}  // namespace

RenderResult render_job(const RenderRequest& request, const RenderLog& log) {
  RenderSettings settings = request.settings;
  const bool auto_mode = request.subsurface == "auto";
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;
  if (!auto_mode && !parse_subsurface_mode(request.subsurface, &mode))
    throw std::invalid_argument("subsurface mode '" + request.subsurface + "': expected random-walk, first-order, table, lambert or auto");
  std::optional<WalkCache> cache;
  if (!request.cache_dir.empty()) cache.emplace(request.cache_dir);

  EnvironmentMap env;
  if (!request.env.empty()) env = EnvironmentMap::from_argument(request.env);
  SceneDesc desc = load_gltf(request.scene_path);
  // Bound before the loader's warnings are printed, so that a binding error is one line.
  const LayeredBindings bindings = bind_layered_materials(desc, request.materials_map_path, request.inline_stacks);
  for (const std::string& w : desc.warnings) say(log.warning, request.scene_path + ": " + w);
  const double aspect = static_cast<double>(settings.width) / settings.height;
  const CameraDesc cam = request.camera_name.empty()
                             ? (desc.cameras.empty() ? framing_camera(desc, aspect) : desc.cameras.front())
                             : find_camera(desc, request.camera_name);
  std::vector<std::string> desc_names;
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) desc_names.push_back(desc.material(static_cast<int>(i)).name);
  const Scene scene(std::move(desc));
  const LightSet lights(scene, env);
  if (lights.empty())
    say(log.warning, request.scene_path + ": no lights, no emissive surfaces and a black environment: the image is black");
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
    as.tolerance = request.tolerance;
    as.table.method = request.table_method;
    const std::vector<bool> visible = camera_visible_materials(scene, camera, settings.width, settings.height);
    choices = choose_subsurface_modes(bindings, as, &visible, cache ? &*cache : nullptr);
    per_material.assign(bindings.by_material.size(), SubsurfaceMode::RandomWalk);
    for (std::size_t i = 0; i < choices.size(); ++i)
      if (bindings.by_material[i]) {
        per_material[i] = choices[i].mode;
        say(log.info, string_printf("auto: material %s (%s): %s [%s%.2f s]", desc_names[i].c_str(),
                             bindings.by_material[i]->source().c_str(), choices[i].reason.c_str(),
                             choices[i].cached ? "from the cache; predicted in " : "", choices[i].seconds));
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
    TableSettings table_settings;
    table_settings.method = request.table_method;
    tables = std::make_unique<LayeredTables>(bindings, table_settings, only, cache ? &*cache : nullptr);
    say(log.info, string_printf("table mode: BRDF/BTDF tables of %d layered material(s): %d built in %.2f s (%d by adding-doubling, "
                                "%d by the walk; %d along texture-driven parameters), %d loaded from %s (%.0f kB)",
                                tabulated, tables->built(), tables->build_seconds(), tables->built() - tables->built_by_walk(),
                                tables->built_by_walk(), tables->parameter_tables(), tables->loaded(),
                                cache ? cache->directory().c_str() : "no cache", tables->bytes() / 1024.0));
  }
  if (bindings.count() > 0 && !auto_mode && mode == SubsurfaceMode::Lambert) {
    // Computed before rendering so that the render's time is the render's.
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& m : bindings.by_material)
      if (m) {
        const Spectrum a = m->lambert_albedo(), se = m->lambert_albedo_stderr();
        // Texture-driven parameters: the albedo model over them, computed now (not in the render).
        if (m->bindings()) m->lambert_albedo_at(glm::dvec2(0.0));
        say(log.info, string_printf("lambert mode: %s: diffuse bihemispherical albedo %.4f %.4f %.4f (+- %.4f %.4f %.4f)",
                             m->source().c_str(), a[0], a[1], a[2], se[0], se[1], se[2]));
      }
    int from_cache = 0;
    for (const auto& m : bindings.by_material) from_cache += m && !m->lambert_albedo_computed() ? 1 : 0;
    say(log.info, string_printf("lambert mode: albedos by adding-doubling (the walk for a rough top) in %.2f s (%d from the cache)",
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), from_cache));
  }
  // What each material's mode leaves out (texture maps, a rough top): a warning and a header key.
  Metadata ignored_meta;
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    const auto& m = bindings.by_material[i];
    if (!m) continue;
    if (auto_mode && (i >= choices.size() || !choices[i].visible)) continue;
    const SubsurfaceMode m_mode = auto_mode ? per_material[i] : mode;
    const std::string ignored = ignored_by_mode(*m, m_mode);
    if (ignored.empty()) continue;
    say(log.warning, string_printf("material %s (%s): the %s mode ignores %s (only random-walk renders them)",
                                   desc_names[i].c_str(), m->source().c_str(), subsurface_mode_name(m_mode), ignored.c_str()));
    ignored_meta.emplace_back("lamina:ignored:" + desc_names[i], ignored);
  }
  // --similarity-after N: an approximation; its bias on each material's diffuse albedo, measured
  // against the exact walk (the lambert mode's albedo, from the cache if there), is printed and
  // recorded before the render.
  Metadata similarity_meta;
  constexpr int kSimilarityBiasWalks = 1 << 15;
  if (request.walk.similarity_after >= 0 && bindings.count() > 0 && uses(SubsurfaceMode::RandomWalk)) {
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
      const auto& m = bindings.by_material[i];
      if (!m) continue;
      LayerStack similar;
      similarity_transform_into(m->base_stack(), &similar);
      WalkSettings ws;
      ws.similarity_after = request.walk.similarity_after;
      ws.similar = &similar;
      Spectrum se_diff, exact;
      const Spectrum diff = diffuse_albedo_bias(m->base_stack(), ws, kSimilarityBiasWalks, LayeredMaterial::kAlbedoSeed, &se_diff, &exact);
      Spectrum bias, se, approx;
      for (int c = 0; c < kChannels; ++c) {
        approx[c] = exact[c] + diff[c];
        bias[c] = exact[c] > 0.0 ? diff[c] / exact[c] : 0.0;
        se[c] = exact[c] > 0.0 ? se_diff[c] / exact[c] : 0.0;
      }
      say(log.info, string_printf("similarity after %d events (approximate): material %s (%s): diffuse albedo %.4f %.4f %.4f "
                                  "against exact %.4f %.4f %.4f: bias %+.1f%% %+.1f%% %+.1f%% (+- %.1f%% %.1f%% %.1f%%)",
                                  request.walk.similarity_after, desc_names[i].c_str(), m->source().c_str(), approx[0], approx[1],
                                  approx[2], exact[0], exact[1], exact[2], 100 * bias[0], 100 * bias[1], 100 * bias[2],
                                  100 * se[0], 100 * se[1], 100 * se[2]));
      similarity_meta.emplace_back("lamina:similarity_bias:" + desc_names[i],
                                   string_printf("%.5f %.5f %.5f +- %.5f %.5f %.5f", bias[0], bias[1], bias[2], se[0], se[1], se[2]));
    }
    say(log.info, string_printf("similarity: bias measured in %.2f s",
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()));
  }
  LayeredShading layered;
  layered.walk = request.walk;
  layered.bindings = &bindings;
  layered.mode = mode;
  layered.per_material = per_material;
  layered.tables = tables.get();
  settings.layered = &layered;

  RenderResult result;
  result.camera = cam.name;
  result.layered_materials = bindings.count();
  const PixelRegion region = settings.crop.empty() ? PixelRegion{0, 0, settings.width, settings.height} : settings.crop;
  const std::uint64_t pixels = static_cast<std::uint64_t>(region.x1 - region.x0) * (region.y1 - region.y0);
  const DataWindow window = settings.crop.empty() ? DataWindow{}
                                                  : DataWindow{region.x0, region.y0, settings.width, settings.height};
  Progress progress("render", pixels * static_cast<std::uint64_t>(settings.spp) +
                                  (settings.noise_threshold > 0.0 ? pixels * settings.pilot_spp : 0));
  RenderProgress on_progress;
  on_progress.advance = [&](std::uint64_t n) { progress.advance(n); };
  on_progress.planned = [&](std::uint64_t total, double converged) {
    progress.set_total(total);
    progress.set_note(string_printf("adaptive: %.0f%% of pixels converge below %d spp", 100.0 * converged, settings.spp));
  };
  // --preview-every: the image so far replaces the outputs (each written atomically), marked as a
  // preview in the header; the final image replaces them in the end.
  on_progress.preview = [&](const Image& so_far, std::uint64_t samples) {
    const Metadata preview_meta = {{"lamina:version", lamina_version()},
                                   {"lamina:command", request.command_line},
                                   {"lamina:scene", request.scene_path},
                                   {"lamina:camera", cam.name},
                                   {"lamina:preview", string_printf("%.6g", static_cast<double>(samples) / static_cast<double>(pixels))}};
    write_exr(request.out_path, so_far, preview_meta, {}, window);
    if (!request.png_path.empty()) write_png(request.png_path, tone_mapped(so_far, request.tone_map));
  };
  RenderAovs aovs;
  const Image image = render_image(scene, lights, camera, settings, &result.stats, on_progress, &aovs);
  progress.finish();
  result.seconds = progress.elapsed_seconds();
  if (cache)
    for (const auto& m : bindings.by_material)
      if (m) store_lambert_albedo(*cache, *m);

  std::ostringstream sec;
  sec << result.seconds;
  const RayCounters& rays = result.stats.rays;
  Metadata meta = {
      {"lamina:version", lamina_version()},
      {"lamina:command", request.command_line},
      {"lamina:scene", request.scene_path},
      {"lamina:camera", cam.name},
      {"lamina:spp", std::to_string(settings.spp)},
      {"lamina:seed", std::to_string(settings.seed)},
      {"lamina:max_depth", std::to_string(settings.max_depth)},
      {"lamina:env", request.env.empty() ? "0" : request.env},
      {"lamina:subsurface", request.subsurface},
      {"lamina:pool_samples", request.walk.per_event_pool_samples ? "per-event" : "shared"},
      {"lamina:similarity_after", std::to_string(request.walk.similarity_after)},
      {"lamina:guiding", string_printf("%.17g", request.walk.guiding)},
      {"lamina:next_flight", request.walk.next_flight ? "on" : "off"},
      {"lamina:noise_threshold", string_printf("%.17g", settings.noise_threshold)},
      {"lamina:pilot_spp", std::to_string(settings.noise_threshold > 0.0 ? settings.pilot_spp : 0)},
      {"lamina:time_limit", string_printf("%.17g", settings.time_limit)},
      {"lamina:time_limit_reached", result.stats.time_limit_reached ? "1" : "0"},
      {"lamina:mean_spp", string_printf("%.6g", mean_spp(result.stats, settings))},
      {"lamina:aovs", aov_names(settings.aovs)},
      {"lamina:clamp", string_printf("%.17g", settings.clamp)},
      {"lamina:clamped_samples", std::to_string(result.stats.clamped_samples)},
      {"lamina:seconds", sec.str()},
      {"lamina:rays_closest", std::to_string(rays.closest)},
      {"lamina:rays_camera", std::to_string(rays.camera)},
      {"lamina:rays_shadow", std::to_string(rays.shadow)},
      {"lamina:layered_materials", std::to_string(bindings.count())},
      {"lamina:scatter_events", std::to_string(rays.scatter_events)},
  };
  if (!settings.crop.empty())
    meta.emplace_back("lamina:crop", string_printf("%d,%d,%d,%d", region.x0, region.y0, region.x1, region.y1));
  meta.insert(meta.end(), similarity_meta.begin(), similarity_meta.end());
  meta.insert(meta.end(), ignored_meta.begin(), ignored_meta.end());
  if (auto_mode) {
    std::ostringstream tol;
    tol << request.tolerance;
    meta.emplace_back("lamina:tolerance", tol.str());
    for (std::size_t i = 0; i < choices.size(); ++i)
      if (bindings.by_material[i]) {
        const MaterialModeChoice c{desc_names[i], choices[i].visible ? subsurface_mode_name(choices[i].mode) : "lambert-hidden",
                                   choices[i].reason};
        meta.emplace_back("lamina:auto:" + c.material, c.reason);
        // The same choice for programs (lamina batch's auto_choices column).
        meta.emplace_back("lamina:auto_mode:" + c.material, c.mode);
        result.auto_choices.push_back(c);
      }
  }
  for (const auto& kv : request.extra_metadata) meta.push_back(kv);
  // The outputs all or none: each is written to a temporary beside it (renderer/util/
  // atomic_file.h), and only when both are written are they renamed into place. A failed write
  // removes the temporaries (the previous files stay); a failed rename of the PNG removes the
  // EXR just renamed. Errors name the output, not its temporary.
  struct Staged {
    std::string tmp, path;
  };
  std::vector<Staged> staged;
  auto stage = [&](const std::string& path, auto&& write) {
    staged.push_back({temporary_path(path), path});
    try {
      write(staged.back().tmp);
    } catch (const std::exception& e) {
      for (const Staged& s : staged) std::remove(s.tmp.c_str());
      std::string message = e.what();
      const std::string& tmp = staged.back().tmp;
      for (std::size_t at = message.find(tmp); at != std::string::npos; at = message.find(tmp, at + path.size()))
        message.replace(at, tmp.size(), path);
      throw ImageIoError(message);
    }
  };
  std::vector<ExtraChannel> extra;
  if (!result.stats.pixel_samples.empty()) {
    ExtraChannel spp{"spp", {}};
    spp.values.assign(result.stats.pixel_samples.begin(), result.stats.pixel_samples.end());
    extra.push_back(std::move(spp));
  }
  // The AOVs, under the names compositors and denoisers look for (docs/contracts.md, "AOVs").
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
  stage(request.out_path, [&](const std::string& tmp) { write_exr(tmp, image, meta, extra, window); });
  if (!request.png_path.empty()) stage(request.png_path, [&](const std::string& tmp) { write_png(tmp, tone_mapped(image, request.tone_map)); });
  for (std::size_t i = 0; i < staged.size(); ++i) {
    try {
      commit_temporary(staged[i].tmp, staged[i].path);  // removes its temporary on failure
    } catch (const AtomicWriteError&) {
      for (std::size_t j = 0; j < i; ++j) std::remove(staged[j].path.c_str());
      for (std::size_t j = i + 1; j < staged.size(); ++j) std::remove(staged[j].tmp.c_str());
      throw;
    }
  }
  result.metadata = std::move(meta);
  return result;
}

}  // namespace lamina
