#include "renderer/layered/stack_bindings.h"
#include "renderer/scene/texture_filter.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "materials/base/sampling.h"
#include "renderer/image/image_io.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/util/paths.h"
#include "materials/stack/json_keys.h"

namespace lamina {
namespace {

using nlohmann::json;

constexpr int kLuminance = 4;
constexpr int kRgb = 5;
// The profile's cut: w is taken to 0 at d = 3r, where exp(-d^2/2r^2) = e^-4.5 ~ 0.011.
constexpr double kCutSquared = 9.0;  // (d/r)^2 at the cut
const double kExpCut = std::exp(-0.5 * kCutSquared);
// Mean spots per cell above which a freckle configuration is rejected: the Poisson draw below
// multiplies uniforms (Knuth), O(mean) per cell, and such a density is a wash, not freckles.
constexpr double kMaxSpotsPerCell = 64.0;


// Knuth's Poisson sampler (TAOCP vol. 2, 3.4.1): multiply uniforms until the product drops
// below e^-mean. Exact; O(mean) uniforms, and mean <= kMaxSpotsPerCell here.
int sample_poisson(double mean, Rng& rng) {
  const double limit = std::exp(-mean);
  double product = rng.uniform_open0();
  int k = 0;
  while (product > limit) {
    ++k;
    product *= rng.uniform_open0();
  }
  return k;
}

}  // namespace

double ParameterMap::lookup(glm::dvec2 uv, int channel) const {
  // The same sampling as Texture::lookup (renderer/scene/texture_filter.h).
  BilinearFootprint f;
  if (!bilinear_footprint(uv, width, height, clamp_s, clamp_t, &f)) return 0.0;
  double s = 0.0;
  for (int k = 0; k < 4; ++k) s += f.weight[k] * values[f.texel[k] * channels + channel];
  return s;
}

std::vector<double> map_nodes(const std::vector<double>& t, int count) {
  if (t.empty()) return {0.0};
  const auto [mn, mx] = std::minmax_element(t.begin(), t.end());
  const double lo = *mn, hi = *mx;
  if (!(hi > lo)) return {lo};
  // 4096 bins over [lo, hi]; nodes sit on bin edges e_i = lo + i w. Prefix sums of the texels'
  // count, sum and sum of squares by bin give an interval's cost sum (x - a)(b - x) in O(1).
  constexpr int kBins = 4096;
  const double w = (hi - lo) / kBins;
  std::vector<double> s0(kBins + 1, 0.0), s1(kBins + 1, 0.0), s2(kBins + 1, 0.0);
  for (double v : t) {
    const int i = std::min(kBins - 1, static_cast<int>((v - lo) / w)) + 1;
    s0[i] += 1.0, s1[i] += v, s2[i] += v * v;
  }
  for (int i = 0; i < kBins; ++i) s0[i + 1] += s0[i], s1[i + 1] += s1[i], s2[i + 1] += s2[i];
  auto edge = [&](int i) { return i == kBins ? hi : lo + i * w; };
  auto cost = [&](int p, int q) {  // bins p .. q-1 between edges p and q
    const double a = edge(p), b = edge(q);
    return -(s2[q] - s2[p]) + (a + b) * (s1[q] - s1[p]) - a * b * (s0[q] - s0[p]);
  };
  std::vector<int> edges = {0, kBins};
  // Gains below the sums' rounding (texels on nodes already) are none.
  const double negligible = 1e-9 * s0[kBins] * (hi - lo) * (hi - lo);
  while (static_cast<int>(edges.size()) < count) {
    double best_gain = negligible;
    int best_split = -1;
    for (std::size_t k = 0; k + 1 < edges.size(); ++k) {
      const int p = edges[k], q = edges[k + 1];
      const double whole = cost(p, q);
      for (int r = p + 1; r < q; ++r) {
        const double gain = whole - cost(p, r) - cost(r, q);
        if (gain > best_gain) best_gain = gain, best_split = r;
      }
    }
    if (best_split < 0) break;  // no interval holds a texel strictly inside: exact already
    edges.insert(std::upper_bound(edges.begin(), edges.end(), best_split), best_split);
  }
  std::vector<double> nodes;
  for (int e : edges) nodes.push_back(edge(e));
  return nodes;
}

ParameterMap read_parameter_map(const std::string& path) {
  // The stored values with no colour transform and no alpha premultiplication (integer files
  // as value / max, 0..255 -> 0..1): what a data map means.
  ChannelImage image;
  try {
    image = read_channels(path);
  } catch (const ImageIoError& e) {
    throw SceneError(path + ": cannot read the parameter map (" + e.what() + ")");
  }
  const int nc = static_cast<int>(image.names.size());
  ParameterMap m;
  m.width = image.width;
  m.height = image.height;
  m.channels = std::min(nc, 4);
  m.values.resize(static_cast<std::size_t>(m.width) * m.height * m.channels);
  for (std::size_t p = 0; p < static_cast<std::size_t>(m.width) * m.height; ++p)
    for (int c = 0; c < m.channels; ++c) {
      const float v = image.values[p * nc + c];
      m.values[p * m.channels + c] = std::isfinite(v) ? v : 0.0f;
    }
  return m;
}

double freckle_profile_integral(double r) {
  // int_0^{3r} (exp(-d^2/2r^2) - c) 2 pi d dd / (1 - c) with c = e^-4.5:
  // = 2 pi r^2 [(1 - c) - 4.5 c] / (1 - c).
  return 2.0 * kPi * r * r * ((1.0 - kExpCut) - 0.5 * kCutSquared * kExpCut) / (1.0 - kExpCut);
}

void Freckles::prepare(double max_tabulated) {
  if (!(radius > 0.0 && radius <= 1.0 / 6.0)) throw std::invalid_argument("radius must lie in (0, 1/6] (UV units)");
  if (!(density >= 0.0) || !std::isfinite(density)) throw std::invalid_argument("density must be >= 0");
  if (!std::isfinite(amplitude)) throw std::invalid_argument("amplitude must be finite");
  // Cells of side 1/n >= 3r (the profile's support), so the 3 x 3 neighbourhood holds every
  // spot that reaches a point.
  cells = std::max(1, static_cast<int>(std::floor(1.0 / (std::sqrt(kCutSquared) * radius))));
  const double mean = density / (static_cast<double>(cells) * cells);
  if (mean > kMaxSpotsPerCell)
    throw std::invalid_argument("density " + std::to_string(density) + " is too high for radius " +
                                std::to_string(radius) + " (more than 64 spots per cell of side 3r)");
  cell_start_.clear();
  spots_.clear();
  const double cell_count = static_cast<double>(cells) * cells;
  if (cell_count > max_tabulated || density > max_tabulated) return;
  cell_start_.reserve(static_cast<std::size_t>(cell_count) + 1);
  for (int wy = 0; wy < cells; ++wy)
    for (int wx = 0; wx < cells; ++wx) {
      cell_start_.push_back(static_cast<std::uint32_t>(spots_.size()));
      draw_cell(wx, wy, [&](const Spot& spot) { spots_.push_back(spot); });
    }
  cell_start_.push_back(static_cast<std::uint32_t>(spots_.size()));
}

template <class Visit>
void Freckles::draw_cell(int wx, int wy, const Visit& visit) const {
  const double mean = density / (static_cast<double>(cells) * cells);
  Rng rng(seed, static_cast<std::uint64_t>(wy) * static_cast<std::uint64_t>(cells) + wx, 0xF4EC1E5ULL);
  const int count = sample_poisson(mean, rng);
  for (int k = 0; k < count; ++k) {
    Spot spot;
    spot.x = rng.uniform();
    spot.y = rng.uniform();
    spot.amplitude = amplitude * (0.5 + 0.5 * rng.uniform());
    visit(spot);
  }
}

double Freckles::value(glm::dvec2 uv) const {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y) || density <= 0.0) return 0.0;
  const int n = cells;
  const double side = 1.0 / n;
  const double u = uv.x - std::floor(uv.x), v = uv.y - std::floor(uv.y);
  const int cx = std::min(static_cast<int>(u * n), n - 1), cy = std::min(static_cast<int>(v * n), n - 1);
  const double inv_2r2 = 1.0 / (2.0 * radius * radius);
  const double cut2 = kCutSquared * radius * radius;
  double sum = 0.0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      // Periodic cell index; the spot positions are placed relative to the unwrapped cell so
      // distances are measured across the seam.
      const int ix = cx + dx, iy = cy + dy;
      const int wx = (ix % n + n) % n, wy = (iy % n + n) % n;
      auto add = [&](const Spot& spot) {
        const double px = (ix + spot.x) * side, py = (iy + spot.y) * side;
        const double d2 = (u - px) * (u - px) + (v - py) * (v - py);
        if (d2 < cut2) sum += spot.amplitude * (std::exp(-d2 * inv_2r2) - kExpCut) / (1.0 - kExpCut);
      };
      if (cell_start_.empty()) {
        draw_cell(wx, wy, add);
      } else {
        const std::size_t c = static_cast<std::size_t>(wy) * static_cast<std::size_t>(n) + wx;
        for (std::uint32_t k = cell_start_[c]; k < cell_start_[c + 1]; ++k) add(spots_[k]);
      }
    }
  return sum;
}

template <class Get>
double StackBindings::Source::driving_value(Get get, int c) const {
  double t;
  if (channel == kLuminance)
    t = 0.2126 * get(0) + 0.7152 * get(std::min(1, map->channels - 1)) + 0.0722 * get(std::min(2, map->channels - 1));
  else if (channel == kRgb)
    t = get(std::min(c, map->channels - 1));
  else
    t = get(channel);
  return std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
}

double StackBindings::Source::sample(glm::dvec2 uv, int c) const {
  return driving_value([&](int k) { return map->lookup(uv, k); }, c);
}

std::vector<double> StackBindings::Source::texel_values(int c) const {
  const std::size_t n = static_cast<std::size_t>(map->width) * map->height;
  std::vector<double> t(n);
  for (std::size_t p = 0; p < n; ++p)
    t[p] = driving_value([&](int k) { return static_cast<double>(map->values[p * map->channels + k]); }, c);
  return t;
}

StackBindings::Source StackBindings::parse_source(const json& j, const std::string& where, bool allow_rgb) {
  auto fail = [&](const std::string& key, const std::string& why) {
    throw SceneError(named_in_ + ": material '" + material_ + "': " + where + "." + key + ": " + why);
  };
  Source s;
  if (!j.contains("texture")) fail("texture", "missing (a file path or a glTF texture index)");
  const json& t = j["texture"];
  bool gltf = false;
  if (t.is_string()) {
    const std::string path = resolve_relative_to(t.get<std::string>(), base_file_);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) fail("texture", "file '" + t.get<std::string>() + "' not found (" + path + ")");
    s.map = std::make_shared<const ParameterMap>(read_parameter_map(path));
    map_files_.push_back(path);
    s.key = "file " + path;
  } else if (t.is_number_integer()) {
    const int index = t.get<int>();
    auto it = scene_->gltf_textures.find(index);
    if (it == scene_->gltf_textures.end()) fail("texture", "glTF texture " + std::to_string(index) + " does not exist");
    const Texture& tex = scene_->textures[it->second];
    ParameterMap m;
    m.width = tex.width;
    m.height = tex.height;
    m.channels = 3;
    m.clamp_s = tex.clamp_s;
    m.clamp_t = tex.clamp_t;
    // The loader decoded the 8-bit values from sRGB; encoding gives back the stored values.
    m.values.resize(tex.rgb.size());
    for (std::size_t i = 0; i < tex.rgb.size(); ++i) m.values[i] = static_cast<float>(srgb_encode(tex.rgb[i]));
    s.map = std::make_shared<const ParameterMap>(std::move(m));
    gltf = true;
    s.key = "glTF texture " + std::to_string(index);
  } else {
    fail("texture", "expected a file path (string) or a glTF texture index (integer)");
  }
  const std::string channel = j.contains("channel") && j["channel"].is_string() ? j["channel"].get<std::string>() : "";
  if (j.contains("channel") && !j["channel"].is_string()) fail("channel", "expected a string");
  const int nch = s.map->channels;
  if (channel == "r" || channel.empty()) s.channel = 0;
  else if (channel == "g") s.channel = nch >= 3 ? 1 : 0;
  else if (channel == "b") s.channel = nch >= 3 ? 2 : 0;
  else if (channel == "a") {
    if (gltf) fail("channel", "the alpha of glTF textures is not kept by the loader: use a file");
    if (nch != 2 && nch != 4) fail("channel", "the map has no alpha channel");
    s.channel = nch - 1;
  } else if (channel == "luminance") s.channel = kLuminance;
  else if (channel == "rgb" && allow_rgb) s.channel = kRgb;
  else fail("channel", "'" + channel + "': expected r, g, b, a, luminance" + std::string(allow_rgb ? " or rgb" : ""));
  s.key += " channel " + std::to_string(s.channel);
  return s;
}

StackBindings::StackBindings(const json& spec, std::shared_ptr<const StackTemplate> stack, const SceneDesc& scene,
                             const std::string& named_in, const std::string& material, const std::string& base_file)
    : template_(std::move(stack)), scene_(&scene), named_in_(named_in), material_(material), base_file_(base_file) {
  auto fail = [&](const std::string& where, const std::string& why) {
    throw SceneError(named_in_ + ": material '" + material_ + "': " + where + ": " + why);
  };
  auto parameter = [&](const json& j, const std::string& where) {
    if (!j.contains("parameter") || !j["parameter"].is_string())
      fail(where + ".parameter", "missing (a stack path such as layers[1].components[0].fraction)");
    try {
      return parse_stack_parameter(*template_, j["parameter"].get<std::string>());
    } catch (const StackParameterError& e) {
      fail(where + ".parameter", e.what());
    }
    return StackParameter{};  // not reached: fail() throws
  };
  auto check_keys = [&](const json& j, const std::string& where, std::initializer_list<const char*> allowed) {
    if (!j.is_object()) fail(where, "expected an object");
    if (const std::string* key = first_unknown_key(j, allowed)) fail(where + "." + *key, "unknown key");
  };
  auto number = [&](const json& j, const std::string& where) {
    if (!j.is_number() || !std::isfinite(j.get<double>())) fail(where, "expected a finite number");
    return j.get<double>();
  };

  if (spec.contains("bind")) {
    const json& binds = spec["bind"];
    if (!binds.is_array()) fail("bind", "expected an array of bindings");
    for (std::size_t i = 0; i < binds.size(); ++i) {
      const std::string where = "bind[" + std::to_string(i) + "]";
      const json& b = binds[i];
      check_keys(b, where, {"parameter", "texture", "channel", "range"});
      const StackParameter p = parameter(b, where);
      Binding binding;
      binding.source = parse_source(b, where, p.spectral());
      if (!b.contains("range") || !b["range"].is_array() || b["range"].size() != 2)
        fail(where + ".range", "expected [value at 0, value at 1]");
      for (int e = 0; e < 2; ++e) {
        const json& r = b["range"][e];
        const std::string rp = where + ".range[" + std::to_string(e) + "]";
        Spectrum v;
        if (r.is_array() && p.spectral() && r.size() == 3) {
          for (int c = 0; c < 3; ++c) v[c] = number(r[c], rp + "[" + std::to_string(c) + "]");
        } else {
          v = Spectrum(number(r, rp));
        }
        for (int c = 0; c < 3; ++c)
          if (v[c] < p.min_value() || v[c] > p.max_value())
            fail(rp, "outside the range of " + p.path + " [" + std::to_string(p.min_value()) + ", " +
                         std::to_string(p.max_value()) + "]");
        (e == 0 ? binding.lo : binding.hi) = v;
      }
      parameters_.push_back(p);
      bindings_.push_back(binding);
    }
  }
  if (spec.contains("freckles")) {
    const json& f = spec["freckles"];
    check_keys(f, "freckles", {"parameter", "density", "radius", "amplitude", "seed", "mask"});
    const StackParameter p = parameter(f, "freckles");
    for (const char* key : {"density", "radius", "amplitude"})
      if (!f.contains(key)) fail(std::string("freckles.") + key, "missing");
    freckles_.density = number(f["density"], "freckles.density");
    freckles_.radius = number(f["radius"], "freckles.radius");
    freckles_.amplitude = number(f["amplitude"], "freckles.amplitude");
    if (f.contains("seed")) {
      if (!f["seed"].is_number_unsigned()) fail("freckles.seed", "expected a non-negative integer");
      freckles_.seed = f["seed"].get<std::uint64_t>();
    }
    try {
      freckles_.prepare();
    } catch (const std::invalid_argument& e) {
      fail("freckles", e.what());
    }
    if (f.contains("mask")) {
      check_keys(f["mask"], "freckles.mask", {"texture", "channel"});
      mask_ = parse_source(f["mask"], "freckles.mask", false);
      has_mask_ = true;
    }
    has_freckles_ = true;
    for (std::size_t k = 0; k < parameters_.size(); ++k)
      if (parameters_[k].path == p.path) freckle_parameter_ = static_cast<int>(k);
    if (freckle_parameter_ < 0) {
      // Not bound to a map: the freckles vary the stack's own value.
      freckle_parameter_ = static_cast<int>(parameters_.size());
      parameters_.push_back(p);
    }
  }
  try {
    check_parameter_set(parameters_);
  } catch (const StackParameterError& e) {
    fail("bind", e.what());
  }
}

void StackBindings::values(glm::dvec2 uv, Spectrum* out) const {
  for (std::size_t k = 0; k < parameters_.size(); ++k) {
    if (k < bindings_.size()) {
      const Binding& b = bindings_[k];
      Spectrum v;
      if (b.source.channel == kRgb) {
        for (int c = 0; c < kChannels; ++c) v[c] = b.lo[c] + (b.hi[c] - b.lo[c]) * b.source.sample(uv, c);
      } else {
        const double t = b.source.sample(uv, 0);
        v = b.lo + (b.hi - b.lo) * t;
      }
      out[k] = v;
    } else {
      out[k] = parameters_[k].template_value(*template_);
    }
  }
  if (has_freckles_) {
    // The mask first: where it is 0 (most of a face) the spots are not summed at all.
    const double mask = has_mask_ ? mask_.sample(uv, 0) : 1.0;
    const double f = mask != 0.0 ? freckles_.value(uv) * mask : 0.0;
    out[freckle_parameter_] += Spectrum(f);
  }
}

void StackBindings::value_range(std::size_t k, Spectrum* lo, Spectrum* hi) const {
  if (k < bindings_.size()) {
    for (int c = 0; c < kChannels; ++c) {
      (*lo)[c] = std::min(bindings_[k].lo[c], bindings_[k].hi[c]);
      (*hi)[c] = std::max(bindings_[k].lo[c], bindings_[k].hi[c]);
    }
  } else {
    *lo = *hi = parameters_[k].template_value(*template_);
  }
  if (has_freckles_ && static_cast<int>(k) == freckle_parameter_) *hi += Spectrum(std::max(0.0, freckles_.amplitude));
}

StackBindings::Nodes StackBindings::nodes(std::size_t k, int count) const {
  Spectrum lo, hi;
  value_range(k, &lo, &hi);
  Nodes n;
  for (int c = 1; c < kChannels; ++c)
    if (hi[c] - lo[c] > hi[n.channel] - lo[n.channel]) n.channel = c;
  if (k < bindings_.size() && !(has_freckles_ && static_cast<int>(k) == freckle_parameter_)) {
    const Binding& b = bindings_[k];
    std::vector<double> texels = b.source.texel_values(n.channel);
    std::vector<double> t = map_nodes(texels, count);
    // Increasing in the channel's value: a binding whose range runs downwards reverses them.
    if (b.hi[n.channel] < b.lo[n.channel]) std::reverse(t.begin(), t.end());
    for (double tj : t) n.values.push_back(b.lo + (b.hi - b.lo) * tj);
    n.even = false;
    n.source = b.source.key + " (channel " + std::to_string(n.channel) + ")";
    n.t = t;
    if (!texels.empty()) {
      auto median = texels.begin() + static_cast<std::ptrdiff_t>(texels.size() / 2);
      std::nth_element(texels.begin(), median, texels.end());
      for (std::size_t j = 1; j < t.size(); ++j)
        if (std::abs(t[j] - *median) < std::abs(t[n.central] - *median)) n.central = j;
    }
    return n;
  }
  const int m = hi[n.channel] > lo[n.channel] ? count : 1;
  for (int j = 0; j < m; ++j) n.values.push_back(lo + (hi - lo) * (m > 1 ? static_cast<double>(j) / (m - 1) : 0.0));
  return n;
}

std::vector<double> StackBindings::texel_values(std::size_t k, int c) const {
  if (k >= bindings_.size()) return {};
  return bindings_[k].source.texel_values(c);
}

void StackBindings::Nodes::bracket(double x, std::size_t* j, double* t) const {
  const double first = values.front()[channel], last = values.back()[channel];
  if (even) {  // evenly spaced: the position in node units, clamped to the range
    const double pos = std::clamp((x - first) / (last - first), 0.0, 1.0) * static_cast<double>(values.size() - 1);
    *j = std::min(static_cast<std::size_t>(pos), values.size() - 2);
    *t = pos - static_cast<double>(*j);
    return;
  }
  const double xc = std::clamp(x, first, last);
  std::size_t i = 1;
  while (i + 1 < values.size() && values[i][channel] < xc) ++i;
  *j = i - 1;
  const double a = values[i - 1][channel], b = values[i][channel];
  *t = std::clamp((xc - a) / (b - a), 0.0, 1.0);
}

void StackBindings::evaluate(glm::dvec2 uv, LayerStack* out) const {
  ParameterValues v(parameters_.size());
  values(uv, v.data());
  apply_parameters(*template_, parameters_, v.data(), out);
}

}  // namespace lamina
