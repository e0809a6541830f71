#include "renderer/layered/spectral_albedo_maps.h"

#include <chrono>

#include <nlohmann/json.hpp>

namespace lamina {

SpectralAlbedoMapsResult fit_spectral_albedo_maps(const ChromophoreMaterial& material, const Image& texture,
                                                  const AlbedoMapsSettings& settings,
                                                  const std::function<void()>& on_lookup_built,
                                                  const std::function<void(std::size_t)>& on_progress) {
  using Clock = std::chrono::steady_clock;
  SpectralAlbedoMapsResult out;
  AlbedoMapsResult& r = out.maps;
  r.width = texture.width;
  r.height = texture.height;
  const auto t0 = Clock::now();
  const SpectralAlbedoTable table = build_spectral_albedo_table(
      material, settings.axes, settings.nodes, AddingDoublingSettings{settings.quadrature_points}, settings.albedo);
  const auto t1 = Clock::now();
  if (on_lookup_built) on_lookup_built();
  const std::size_t texels = static_cast<std::size_t>(texture.width) * texture.height;
  r.match = match_spectral_albedo_map(table, texture.rgb.data(), texels, on_progress);
  const auto t2 = Clock::now();
  summarise_albedo_match(settings, &r);
  for (std::size_t i = 0; i < texels; ++i) {
    bool at_bound = false;
    for (int a = 0; a < 2; ++a) {
      const double v = r.match.value[a][i];
      at_bound = at_bound || v <= settings.axes[a].lower || v >= settings.axes[a].upper;  // the match clamps exactly
    }
    if (at_bound) ++out.clamped;
  }
  r.lookup_seconds = std::chrono::duration<double>(t1 - t0).count();
  r.matching_seconds = std::chrono::duration<double>(t2 - t1).count();
  return out;
}

std::string spectral_albedo_maps_report_json(const SpectralAlbedoMapsResult& result, const AlbedoMapsSettings& settings,
                                             const AlbedoMapsInputs& inputs) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(albedo_maps_report_json(result.maps, settings, inputs));
  j["method"] = "spectral-albedo-lookup";
  j["lookup"]["wavelengths_nm"] = {360, 780, 5};
  j["lookup"]["interpolation"] = "bicubic";
  const std::size_t texels = result.maps.match.delta_e.size();
  j["clamped"] = {{"texels", result.clamped}, {"fraction", texels ? static_cast<double>(result.clamped) / texels : 0.0}};
  return j.dump(2) + "\n";
}

}  // namespace lamina
