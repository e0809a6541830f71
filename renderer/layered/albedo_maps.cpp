#include "renderer/layered/albedo_maps.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

namespace lamina {

void check_albedo_texture(const Image& texture, const std::string& path) {
  for (int y = 0; y < texture.height; ++y)
    for (int x = 0; x < texture.width; ++x) {
      const float* p = texture.pixel(x, y);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        throw ImageIoError(path + ": texel (" + std::to_string(x) + ", " + std::to_string(y) + ") is not finite");
    }
}

AlbedoMapsResult fit_albedo_maps(const StackTemplate& stack, const Image& texture, const AlbedoMapsSettings& settings,
                                 const std::function<void()>& on_lookup_built,
                                 const std::function<void(std::size_t)>& on_progress) {
  using Clock = std::chrono::steady_clock;
  AlbedoMapsResult r;
  r.width = texture.width;
  r.height = texture.height;
  const auto t0 = Clock::now();
  const AlbedoLookup table =
      build_albedo_lookup(stack, settings.axes, settings.nodes, AddingDoublingSettings{settings.quadrature_points}, settings.albedo);
  const auto t1 = Clock::now();
  if (on_lookup_built) on_lookup_built();
  const std::size_t texels = static_cast<std::size_t>(texture.width) * texture.height;
  r.match = match_albedo_map(table, texture.rgb.data(), texels, on_progress);
  const auto t2 = Clock::now();
  summarise_albedo_match(settings, &r);
  r.lookup_seconds = std::chrono::duration<double>(t1 - t0).count();
  r.matching_seconds = std::chrono::duration<double>(t2 - t1).count();
  return r;
}

void summarise_albedo_match(const AlbedoMapsSettings& settings, AlbedoMapsResult* r) {
  r->delta_e = delta_e_statistics(r->match.delta_e, settings.unreachable_delta_e);
  for (int a = 0; a < 2; ++a) {
    // At a bound to 1e-6 of the range: BOBYQA stops on the bound itself.
    const double lo = settings.axes[a].lower, hi = settings.axes[a].upper, eps = 1e-6 * (hi - lo);
    r->at_lower[a] = r->at_upper[a] = 0;
    for (double v : r->match.value[a]) {
      if (v <= lo + eps) ++r->at_lower[a];
      if (v >= hi - eps) ++r->at_upper[a];
    }
  }
}

std::string parameter_map_file_name(const std::string& path) {
  std::string name;
  for (char c : path)
    if (c != '[' && c != ']') name += c;
  return name + ".png";
}

std::vector<float> parameter_map_values(const AlbedoMapsResult& result, const AlbedoMapsSettings& settings, int axis) {
  const FitParameterSpec& a = settings.axes[axis];
  const std::vector<double>& v = result.match.value[axis];
  std::vector<float> t(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) t[i] = static_cast<float>((v[i] - a.lower) / (a.upper - a.lower));
  return t;
}

Image fitted_albedo_image(const AlbedoMapsResult& result) {
  Image image(result.width, result.height);
  for (std::size_t i = 0; i < result.match.albedo.size(); ++i)
    for (int c = 0; c < 3; ++c) image.rgb[3 * i + c] = static_cast<float>(result.match.albedo[i][c]);
  return image;
}

std::string albedo_materials_map_json(const std::string& material, const std::string& stack_reference,
                                      const AlbedoMapsSettings& settings) {
  nlohmann::ordered_json bind = nlohmann::ordered_json::array();
  for (const FitParameterSpec& a : settings.axes)
    bind.push_back({{"parameter", a.path},
                    {"texture", parameter_map_file_name(a.path)},
                    {"channel", "r"},
                    {"range", {a.lower, a.upper}}});
  nlohmann::ordered_json j;
  j[material] = {{"stack", stack_reference}, {"bind", bind}};
  return j.dump(2) + "\n";
}

std::string albedo_maps_report_json(const AlbedoMapsResult& r, const AlbedoMapsSettings& s, const AlbedoMapsInputs& in) {
  const std::size_t texels = r.match.delta_e.size();
  nlohmann::ordered_json j;
  j["method"] = "albedo-lookup";
  j["texture"] = in.texture;
  j["texture_decoding"] = in.texture_decoding;
  j["width"] = r.width;
  j["height"] = r.height;
  j["texels"] = texels;
  j["stack"] = in.stack;
  j["material"] = in.material;
  j["lookup"] = {{"nodes", s.nodes}, {"quadrature_points", s.quadrature_points}, {"albedo", s.albedo == AlbedoKind::kDiffuse ? "diffuse" : "total"}};
  nlohmann::ordered_json ps = nlohmann::ordered_json::array();
  for (int a = 0; a < 2; ++a) {
    const std::vector<double>& v = r.match.value[a];
    double mean = 0.0, lo = v.empty() ? 0.0 : v[0], hi = lo;
    for (double x : v) mean += x, lo = std::min(lo, x), hi = std::max(hi, x);
    if (!v.empty()) mean /= static_cast<double>(v.size());
    ps.push_back({{"name", s.axes[a].path},
                  {"lower", s.axes[a].lower},
                  {"upper", s.axes[a].upper},
                  {"map", parameter_map_file_name(s.axes[a].path)},
                  {"encoding", "16-bit grey PNG, linear: value = lower + (upper - lower) * stored / 65535"},
                  {"min", lo},
                  {"mean", mean},
                  {"max", hi},
                  {"texels_at_lower", r.at_lower[a]},
                  {"texels_at_upper", r.at_upper[a]}});
  }
  j["parameters"] = ps;
  j["delta_e76"] = {{"mean", r.delta_e.mean}, {"median", r.delta_e.median}, {"p95", r.delta_e.p95}, {"max", r.delta_e.max}};
  j["unreachable"] = {{"delta_e_above", s.unreachable_delta_e},
                      {"texels", r.delta_e.above},
                      {"fraction", texels ? static_cast<double>(r.delta_e.above) / static_cast<double>(texels) : 0.0}};
  j["materials_map"] = in.materials_map;
  j["fitted_albedo"] = in.fitted_albedo;
  j["threads"] = in.threads;
  j["seconds"] = {{"lookup", r.lookup_seconds}, {"matching", r.matching_seconds}, {"total", in.total_seconds}};
  return j.dump(2) + "\n";
}

}  // namespace lamina
