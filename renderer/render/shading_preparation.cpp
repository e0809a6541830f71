#include "renderer/render/shading_preparation.h"

#include <chrono>
#include <stdexcept>
#include <string>

#include "materials/tables/albedo.h"
#include "materials/walk/random_walk.h"
#include "renderer/layered/spectral_tables.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/layered/wavelength_stack.h"
#include "renderer/render/render_job.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/camera_visibility.h"
#include "renderer/scene/scene.h"
#include "renderer/util/string_format.h"

namespace lamina {
namespace {

void say(const std::function<void(const std::string&)>& to, const std::string& line) {
  if (to) to(line);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The mode of material slot i (auto's choice, or the one mode).
SubsurfaceMode mode_of(const ShadingInputs& in, const PreparedShading& out, std::size_t i) {
  return in.subsurface.automatic ? out.layered.per_material[i] : in.subsurface.mode;
}

// Whether some layered material is shaded in mode m.
bool uses(const ShadingInputs& in, const PreparedShading& out, SubsurfaceMode m) {
  if (!in.subsurface.automatic) return in.subsurface.mode == m;
  const auto& by_material = in.bindings->by_material;
  for (std::size_t i = 0; i < by_material.size(); ++i)
    if (by_material[i] && out.layered.per_material[i] == m) return true;
  return false;
}

// --subsurface auto: a mode per material, predicted from its BSDF (renderer/layered/
// subsurface_auto.h). Only materials that camera rays of a coarse grid hit are predicted.
void choose_modes(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const LayeredBindings& bindings = *in.bindings;
  AutoSettings as;
  as.tolerance = in.subsurface.tolerance;
  as.table.method = in.table_method;
  const std::vector<bool> visible = camera_visible_materials(*in.scene, *in.camera, in.width, in.height);
  out->choices = choose_subsurface_modes(bindings, as, &visible, in.cache);
  out->layered.per_material.assign(bindings.by_material.size(), SubsurfaceMode::RandomWalk);
  for (std::size_t i = 0; i < out->choices.size(); ++i)
    if (bindings.by_material[i]) {
      const AutoChoice& c = out->choices[i];
      out->layered.per_material[i] = c.mode;
      say(log.info, string_printf("auto: material %s (%s): %s [%s%.2f s]", (*in.material_names)[i].c_str(),
                                  bindings.by_material[i]->source().c_str(), c.reason.c_str(),
                                  c.cached ? "from the cache; predicted in " : "", c.seconds));
    }
}

// The table mode's tables, of the materials that use it.
void build_tables(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const LayeredBindings& bindings = *in.bindings;
  std::vector<bool> only(bindings.by_material.size(), true);
  if (in.subsurface.automatic)
    for (std::size_t i = 0; i < only.size(); ++i) only[i] = out->layered.per_material[i] == SubsurfaceMode::Table;
  int tabulated = 0;
  for (std::size_t i = 0; i < only.size(); ++i) tabulated += only[i] && bindings.by_material[i] ? 1 : 0;
  TableSettings table_settings;
  table_settings.method = in.table_method;
  out->tables = std::make_unique<LayeredTables>(bindings, table_settings, only, in.cache);
  const LayeredTables& t = *out->tables;
  say(log.info, string_printf("table mode: BRDF/BTDF tables of %d layered material(s): %d built in %.2f s (%d by adding-doubling, "
                              "%d by the walk; %d along texture-driven parameters), %d loaded from %s (%.0f kB)",
                              tabulated, t.built(), t.build_seconds(), t.built() - t.built_by_walk(), t.built_by_walk(),
                              t.parameter_tables(), t.loaded(), in.cache ? in.cache->directory().c_str() : "no cache",
                              t.bytes() / 1024.0));
}

// In the spectral mode, whether material slot i has leaf layers (their index varies with the
// wavelength: only the walk follows one wavelength through them, renderer/layered/shading.h).
bool has_spectral_leaf_layers(const ShadingInputs& in, std::size_t i) {
  return in.spectral && i < in.spectral->size() && (*in.spectral)[i] && has_leaf_layers(*(*in.spectral)[i]);
}

// The spectral mode with one --subsurface mode other than the walk: leaf layers are refused in
// one line naming the file, before any table is built.
void refuse_unwalked_leaves(const ShadingInputs& in) {
  const auto& by_material = in.bindings->by_material;
  for (std::size_t i = 0; i < by_material.size(); ++i)
    if (by_material[i] && has_spectral_leaf_layers(in, i))
      throw std::runtime_error(by_material[i]->source() + ": leaf layers are rendered spectrally by the walk alone (their "
                               "index varies with the wavelength): use --subsurface random-walk or auto");
}

// The spectral mode under auto: a material whose chromophores are bound to maps is not tabulated
// per wavelength (renderer/layered/spectral_tables.h), so where auto chose table or lambert for it
// (or left it hidden, as lambert) the walk renders it; a material with leaf layers is walked
// whatever auto chose.
void walk_untabulated_materials(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const auto& by_material = in.bindings->by_material;
  for (std::size_t i = 0; i < by_material.size(); ++i) {
    SubsurfaceMode& mode = out->layered.per_material[i];
    if (!by_material[i] || mode == SubsurfaceMode::RandomWalk) continue;
    const char* why = nullptr;
    if (has_spectral_leaf_layers(in, i))
      why = "leaf layers' index varies with the wavelength";
    else if (binds_chromophores(*by_material[i]) && mode != SubsurfaceMode::FirstOrder)
      why = "chromophores bound to maps are not tabulated per wavelength";
    if (!why) continue;
    mode = SubsurfaceMode::RandomWalk;
    AutoChoice& c = out->choices[i];
    c.mode = mode;
    c.visible = true;
    c.reason += std::string("; random-walk in the spectral mode (") + why + ")";
    say(log.info, "auto: material " + (*in.material_names)[i] + ": " + c.reason);
  }
}

// The spectral mode's tables and Lambert albedos on its wavelength grid, of the materials that
// use them (renderer/layered/spectral_tables.h).
void build_spectral_tables(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const auto& by_material = in.bindings->by_material;
  std::vector<bool> tables(by_material.size()), albedos(by_material.size());
  for (std::size_t i = 0; i < by_material.size(); ++i) {
    tables[i] = by_material[i] && mode_of(in, *out, i) == SubsurfaceMode::Table;
    albedos[i] = by_material[i] && mode_of(in, *out, i) == SubsurfaceMode::Lambert;
  }
  TableSettings table_settings;
  table_settings.method = in.table_method;
  out->spectral_tables = std::make_unique<SpectralTables>(*in.bindings, *in.spectral, out->tables.get(), tables, albedos,
                                                          table_settings, in.cache);
  const SpectralTables& s = *out->spectral_tables;
  say(log.info, string_printf("spectral mode: tables and albedos on %d wavelengths (360-830 nm every %.1f nm): %d table(s) "
                              "(%d loaded from the cache) in %.2f s",
                              s.grid().count, s.grid().nm(1) - s.grid().nm(0), s.tables(), s.tables_loaded(), s.seconds()));
}

// The lambert mode's albedos, computed before rendering so that the render's time is the render's.
void compute_lambert_albedos(const ShadingInputs& in, const RenderLog& log) {
  const auto t0 = std::chrono::steady_clock::now();
  for (const auto& m : in.bindings->by_material)
    if (m) {
      const Spectrum a = m->lambert_albedo(), se = m->lambert_albedo_stderr();
      // Texture-driven parameters: the albedo model over them, computed now (not in the render).
      if (m->bindings()) m->lambert_albedo_at(glm::dvec2(0.0));
      say(log.info, string_printf("lambert mode: %s: diffuse bihemispherical albedo %.4f %.4f %.4f (+- %.4f %.4f %.4f)",
                                  m->source().c_str(), a[0], a[1], a[2], se[0], se[1], se[2]));
    }
  int from_cache = 0;
  for (const auto& m : in.bindings->by_material) from_cache += m && !m->lambert_albedo_computed() ? 1 : 0;
  say(log.info, string_printf("lambert mode: albedos by adding-doubling in %.2f s (%d from the cache)",
                              seconds_since(t0), from_cache));
}

// What each material's mode leaves out (texture maps, a rough top): a warning and a header key.
void report_ignored(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const auto& by_material = in.bindings->by_material;
  for (std::size_t i = 0; i < by_material.size(); ++i) {
    const auto& m = by_material[i];
    if (!m) continue;
    if (in.subsurface.automatic && (i >= out->choices.size() || !out->choices[i].visible)) continue;
    const SubsurfaceMode mode = mode_of(in, *out, i);
    const std::string ignored = ignored_by_mode(*m, mode);
    if (ignored.empty()) continue;
    const std::string& name = (*in.material_names)[i];
    say(log.warning, string_printf("material %s (%s): the %s mode ignores %s (only random-walk renders them)", name.c_str(),
                                   m->source().c_str(), subsurface_mode_name(mode), ignored.c_str()));
    out->ignored.emplace_back("lamina:ignored:" + name, ignored);
  }
}

// --similarity-after N: an approximation; its bias on each material's diffuse albedo, measured
// against the exact walk (the lambert mode's albedo, from the cache if there), is printed and
// recorded before the render.
void measure_similarity_bias(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  constexpr int kSimilarityBiasWalks = 1 << 15;
  const auto t0 = std::chrono::steady_clock::now();
  const auto& by_material = in.bindings->by_material;
  for (std::size_t i = 0; i < by_material.size(); ++i) {
    const auto& m = by_material[i];
    if (!m) continue;
    LayerStack similar;
    similarity_transform_into(m->base_stack(), &similar);
    WalkOptions ws;
    ws.similarity_after = in.walk.similarity_after;
    ws.similar = &similar;
    Spectrum se_diff, exact;
    const Spectrum diff = diffuse_albedo_bias(m->base_stack(), ws, kSimilarityBiasWalks, LayeredMaterial::kAlbedoSeed, &se_diff, &exact);
    Spectrum bias, se, approx;
    for (int c = 0; c < kChannels; ++c) {
      approx[c] = exact[c] + diff[c];
      bias[c] = exact[c] > 0.0 ? diff[c] / exact[c] : 0.0;
      se[c] = exact[c] > 0.0 ? se_diff[c] / exact[c] : 0.0;
    }
    const std::string& name = (*in.material_names)[i];
    say(log.info, string_printf("similarity after %d events (approximate): material %s (%s): diffuse albedo %.4f %.4f %.4f "
                                "against exact %.4f %.4f %.4f: bias %+.1f%% %+.1f%% %+.1f%% (+- %.1f%% %.1f%% %.1f%%)",
                                in.walk.similarity_after, name.c_str(), m->source().c_str(), approx[0], approx[1], approx[2],
                                exact[0], exact[1], exact[2], 100 * bias[0], 100 * bias[1], 100 * bias[2], 100 * se[0],
                                100 * se[1], 100 * se[2]));
    out->similarity_bias.emplace_back("lamina:similarity_bias:" + name, string_printf("%.5f %.5f %.5f +- %.5f %.5f %.5f", bias[0],
                                                                                      bias[1], bias[2], se[0], se[1], se[2]));
  }
  say(log.info, string_printf("similarity: bias measured in %.2f s", seconds_since(t0)));
}

// Diffusely transmitting interfaces (docs/layered_rendering.md): first-order does not model them
// (under auto a material that has one is walked instead of first-order), and the walk models
// them on the stack's outside alone. Refused in one line naming the file.
void check_diffuse_interfaces(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const auto& by_material = in.bindings->by_material;
  for (std::size_t i = 0; i < by_material.size(); ++i) {
    if (!by_material[i] || !by_material[i]->base_stack().any_diffuse_interface()) continue;
    const LayerStack& stack = by_material[i]->base_stack();
    bool inner = false;  // a diffuse interface between two layers
    for (int k = 1; k < static_cast<int>(stack.layers.size()); ++k) inner = inner || stack.diffuse_interface(k);
    const std::string& source = by_material[i]->source();
    if (in.subsurface.automatic && out->layered.per_material[i] == SubsurfaceMode::FirstOrder) {
      out->layered.per_material[i] = SubsurfaceMode::RandomWalk;
      AutoChoice& c = out->choices[i];
      c.mode = SubsurfaceMode::RandomWalk;
      c.reason += "; random-walk (first-order does not model a diffusely transmitting interface)";
      say(log.info, "auto: material " + (*in.material_names)[i] + ": " + c.reason);
    }
    const SubsurfaceMode mode = mode_of(in, *out, i);
    if (mode == SubsurfaceMode::FirstOrder)
      throw std::runtime_error(source + ": " + stack.first_diffuse_interface_path() +
                               ": first-order does not model a diffuse interface: use random-walk, table, lambert or auto");
    if (mode == SubsurfaceMode::RandomWalk && inner)
      throw std::runtime_error(source + ": " + stack.first_diffuse_interface_path() +
                               ": the walk renders a diffuse interface at the top or the bottom only, not between two "
                               "layers: use table or lambert");
  }
}

}  // namespace

void prepare_shading(const ShadingInputs& in, const RenderLog& log, PreparedShading* out) {
  const LayeredBindings& bindings = *in.bindings;
  // Lambert albedos computed by an earlier run (the lambert mode's, auto's lambert model).
  if (in.cache)
    for (const auto& m : bindings.by_material)
      if (m) load_lambert_albedo(*in.cache, *m);
  if (in.subsurface.automatic) choose_modes(in, log, out);
  check_diffuse_interfaces(in, log, out);
  if (in.spectral && !in.subsurface.automatic && in.subsurface.mode != SubsurfaceMode::RandomWalk) refuse_unwalked_leaves(in);
  if (in.subsurface.automatic && in.spectral) walk_untabulated_materials(in, log, out);
  const bool any = bindings.count() > 0;
  if (any && uses(in, *out, SubsurfaceMode::Table)) build_tables(in, log, out);
  if (any && !in.subsurface.automatic && in.subsurface.mode == SubsurfaceMode::Lambert) compute_lambert_albedos(in, log);
  if (any && in.spectral && (uses(in, *out, SubsurfaceMode::Table) || uses(in, *out, SubsurfaceMode::Lambert)))
    build_spectral_tables(in, log, out);
  report_ignored(in, log, out);
  if (in.walk.similarity_after >= 0 && any && uses(in, *out, SubsurfaceMode::RandomWalk)) measure_similarity_bias(in, log, out);
  out->layered.walk = in.walk;
  out->layered.bindings = &bindings;
  out->layered.mode = in.subsurface.mode;
  out->layered.tables = out->tables.get();
  out->layered.spectral_tables = out->spectral_tables.get();
}

}  // namespace lamina
