#include "materials/stack/stack.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "materials/phase/henyey_greenstein.h"

namespace lamina {

Spectrum Layer::sigma_s() const {
  Spectrum s;
  for (const PhaseLobe& lobe : lobes) s += lobe.sigma_s;
  return s;
}

Spectrum Layer::albedo() const {
  const Spectrum s = sigma_s();
  const Spectrum t = sigma_a + s;
  Spectrum a;
  for (int c = 0; c < kChannels; ++c) a[c] = t[c] > 0.0 ? s[c] / t[c] : 0.0;
  return a;
}

double Layer::optical_depth(int channel) const {
  const double st = sigma_t()[channel];
  if (st == 0.0) return 0.0;
  return st * thickness;
}

double Layer::phase(int channel, double cos_theta) const {
  double total = 0.0, value = 0.0;
  for (const PhaseLobe& lobe : lobes) {
    total += lobe.sigma_s[channel];
    value += lobe.sigma_s[channel] * henyey_greenstein(cos_theta, lobe.g[channel]);
  }
  return total > 0.0 ? value / total : 0.0;
}

int Layer::choose_lobe(int channel, double u) const {
  const int n = static_cast<int>(lobes.size());
  if (n <= 1) return 0;
  double total = 0.0;
  for (const PhaseLobe& lobe : lobes) total += lobe.sigma_s[channel];
  double target = u * total;
  for (int i = 0; i < n; ++i) {
    target -= lobes[i].sigma_s[channel];
    if (target < 0.0) return i;
  }
  return n - 1;
}

Layer make_layer(std::string name, double ior, double thickness, Spectrum sigma_a,
                 Spectrum sigma_s, Spectrum g) {
  Layer layer;
  layer.name = std::move(name);
  layer.ior = ior;
  layer.thickness = thickness;
  layer.sigma_a = sigma_a;
  layer.lobes.push_back({sigma_s, g});
  return layer;
}

bool LayerStack::transmits() const {
  if (below.kind != Below::Kind::Dielectric) return false;
  for (const Layer& layer : layers)
    if (layer.semi_infinite()) return false;
  return true;
}

bool LayerStack::grey() const {
  for (const Layer& layer : layers) {
    if (!layer.sigma_a.is_grey()) return false;
    for (const PhaseLobe& lobe : layer.lobes)
      if (!lobe.sigma_s.is_grey() || !lobe.g.is_grey()) return false;
  }
  return below.kind != Below::Kind::Lambert || below.albedo.is_grey();
}

double LayerStack::ior_above_interface(int k) const {
  return k == 0 ? above_ior : layers[k - 1].ior;
}

double LayerStack::ior_below_interface(int k) const {
  const int n = static_cast<int>(layers.size());
  if (k < n) return layers[k].ior;
  return below.kind == Below::Kind::Dielectric ? below.ior : layers[n - 1].ior;
}

LayerStack flipped(const LayerStack& stack) {
  if (!stack.transmits())
    throw std::invalid_argument("flipped(): stack '" + stack.name +
                                "' has an opaque bottom (Lambert substrate or semi-infinite layer)");
  LayerStack f;
  flip_into(stack, &f);
  return f;
}

void similarity_transform_into(const LayerStack& stack, LayerStack* out) {
  *out = stack;
  for (Layer& layer : out->layers)
    for (PhaseLobe& lobe : layer.lobes) {
      for (int c = 0; c < kChannels; ++c) lobe.sigma_s[c] *= 1.0 - lobe.g[c];
      lobe.g = Spectrum(0.0);
    }
}

void flip_into(const LayerStack& stack, LayerStack* out) {
  *out = stack;
  std::reverse(out->layers.begin(), out->layers.end());
  out->above_ior = stack.below.ior;
  out->below.ior = stack.above_ior;
  // Interface k of the flipped stack is interface N - k of the stack: the old bottom is the new
  // top, and new layer j's bottom is the old interface above old layer N - 1 - j.
  const std::size_t n = stack.layers.size();
  out->top_roughness = n > 0 ? stack.layers[n - 1].bottom_roughness : 0.0;
  out->top_diffuse = n > 0 && stack.layers[n - 1].bottom_diffuse;
  for (std::size_t j = 0; j < n; ++j) {
    out->layers[j].bottom_roughness = j + 1 < n ? stack.layers[n - 2 - j].bottom_roughness : stack.top_roughness;
    out->layers[j].bottom_diffuse = j + 1 < n ? stack.layers[n - 2 - j].bottom_diffuse : stack.top_diffuse;
  }
}

LayerStack with_smooth_top(LayerStack stack) {
  stack.top_roughness = 0.0;
  for (Layer& layer : stack.layers) layer.bottom_roughness = 0.0;
  return stack;
}

double LayerStack::energy_conserving_alpha(int k) const {
  const int n = static_cast<int>(layers.size());
  if (interface_model != InterfaceModel::EnergyConserving || k < 0 || k > n || n == 0) return 0.0;
  const double alpha = k == 0 ? top_roughness : layers[k - 1].bottom_roughness;
  if (!(alpha > 0.0)) return 0.0;
  if (k == n && below.kind != Below::Kind::Dielectric) return 0.0;
  return ior_above_interface(k) != ior_below_interface(k) ? alpha : 0.0;
}

bool LayerStack::energy_conserving_rough() const {
  for (int k = 0; k <= static_cast<int>(layers.size()); ++k)
    if (energy_conserving_alpha(k) > 0.0) return true;
  return false;
}

bool LayerStack::diffuse_interface(int k) const {
  const int n = static_cast<int>(layers.size());
  if (k < 0 || k > n || n == 0) return false;
  if (!(k == 0 ? top_diffuse : layers[k - 1].bottom_diffuse)) return false;
  if (k == n && below.kind != Below::Kind::Dielectric) return false;
  return ior_above_interface(k) != ior_below_interface(k);
}

bool LayerStack::any_diffuse_interface() const { return !first_diffuse_interface_path().empty(); }

std::string LayerStack::first_diffuse_interface_path() const {
  for (int k = 0; k <= static_cast<int>(layers.size()); ++k)
    if (diffuse_interface(k)) return k == 0 ? "top_diffuse" : "layers[" + std::to_string(k - 1) + "].bottom_diffuse";
  return {};
}

std::string stack_fingerprint(const LayerStack& stack) {
  std::ostringstream out;
  out << std::hexfloat;
  auto spectrum = [&](const Spectrum& v) {
    for (int c = 0; c < kChannels; ++c) out << ' ' << v[c];
  };
  out << "above " << stack.above_ior << '\n';
  if (stack.rough_top()) out << "top_roughness " << stack.top_roughness << '\n';
  if (stack.diffuse_interface(0)) out << "top_diffuse\n";
  if (stack.interface_model == InterfaceModel::EnergyConserving) out << "energy_conserving\n";
  for (const Layer& l : stack.layers) {
    out << "layer " << l.ior << ' ' << l.thickness << " sigma_a";
    if (l.bottom_roughness > 0.0) out << " bottom_roughness " << l.bottom_roughness;
    if (l.bottom_diffuse) out << " bottom_diffuse";
    spectrum(l.sigma_a);
    for (const PhaseLobe& lobe : l.lobes) {
      out << " lobe";
      spectrum(lobe.sigma_s);
      spectrum(lobe.g);
    }
    out << '\n';
  }
  out << "below " << (stack.below.kind == Below::Kind::Dielectric ? "dielectric " : "lambert ") << stack.below.ior;
  spectrum(stack.below.albedo);
  out << '\n';
  return out.str();
}

namespace {

bool bad_coefficient(double v) { return !std::isfinite(v) || v < 0.0; }

std::string check_spectrum(const std::string& path, const Spectrum& s, bool unit_interval) {
  for (int c = 0; c < kChannels; ++c) {
    if (bad_coefficient(s[c])) {
      std::ostringstream os;
      os << path << "[" << c << "]: must be finite and >= 0 (got " << s[c] << ")";
      return os.str();
    }
    if (unit_interval && s[c] > 1.0) {
      std::ostringstream os;
      os << path << "[" << c << "]: must be <= 1 (got " << s[c] << ")";
      return os.str();
    }
  }
  return {};
}

std::string check_ior(const std::string& path, double n) {
  if (!std::isfinite(n) || n <= 0.0) {
    std::ostringstream os;
    os << path << ": index of refraction must be finite and > 0 (got " << n << ")";
    return os.str();
  }
  return {};
}

}  // namespace

std::string validate_stack(const LayerStack& stack) {
  if (auto e = check_ior("above_ior", stack.above_ior); !e.empty()) return e;
  if (stack.layers.empty()) return "layers: a stack needs at least one layer";
  if (!std::isfinite(stack.top_roughness) || stack.top_roughness < 0.0 || stack.top_roughness > 1.0) {
    std::ostringstream os;
    os << "roughness: must be a number in [0, 1] (GGX alpha; got " << stack.top_roughness << ")";
    return os.str();
  }
  if (stack.top_diffuse && stack.top_roughness > 0.0)
    return "top_diffuse: a diffuse interface cannot also be rough (roughness " + std::to_string(stack.top_roughness) +
           "): give one of them";
  for (std::size_t i = 0; i < stack.layers.size(); ++i) {
    const Layer& layer = stack.layers[i];
    const std::string p = "layers[" + std::to_string(i) + "]";
    if (auto e = check_ior(p + ".ior", layer.ior); !e.empty()) return e;
    if (!std::isfinite(layer.bottom_roughness) || layer.bottom_roughness < 0.0 || layer.bottom_roughness > 1.0) {
      std::ostringstream os;
      os << p << ".bottom_roughness: must be a number in [0, 1] (GGX alpha; got " << layer.bottom_roughness << ")";
      return os.str();
    }
    if (layer.bottom_roughness > 0.0 && stack.interface_model != InterfaceModel::EnergyConserving)
      return p + ".bottom_roughness: rough inner and bottom interfaces need \"interface_model\": "
                 "\"energy_conserving\"";
    if (layer.bottom_roughness > 0.0 && i + 1 == stack.layers.size() &&
        (stack.below.kind != Below::Kind::Dielectric || layer.semi_infinite()))
      return p + ".bottom_roughness: the last layer has no bottom interface (a lambert substrate or a "
                 "semi-infinite layer)";
    if (layer.bottom_diffuse && layer.bottom_roughness > 0.0)
      return p + ".bottom_diffuse: a diffuse interface cannot also be rough (bottom_roughness " +
             std::to_string(layer.bottom_roughness) + "): give one of them";
    if (layer.bottom_diffuse && i + 1 == stack.layers.size() &&
        (stack.below.kind != Below::Kind::Dielectric || layer.semi_infinite()))
      return p + ".bottom_diffuse: the last layer has no bottom interface (a lambert substrate or a "
                 "semi-infinite layer)";
    if (std::isnan(layer.thickness) || layer.thickness < 0.0)
      return p + ".thickness: must be >= 0 or \"inf\"";
    if (layer.semi_infinite() && i + 1 != stack.layers.size())
      return p + ".thickness: only the last layer may be semi-infinite (\"inf\")";
    if (auto e = check_spectrum(p + ".sigma_a", layer.sigma_a, false); !e.empty()) return e;
    if (layer.lobes.empty()) return p + ": a layer needs at least one phase lobe";
    if (layer.semi_infinite()) {
      // Light entering a semi-infinite layer that cannot collide would travel forever: the
      // model (and the random walk) needs sigma_t > 0 there.
      for (int c = 0; c < kChannels; ++c)
        if (!(layer.sigma_t()[c] > 0.0))
          return p + ": a semi-infinite layer needs sigma_a + sigma_s > 0 in every channel (channel " +
                 std::to_string(c) + " is 0)";
    }
    for (std::size_t j = 0; j < layer.lobes.size(); ++j) {
      const std::string q = layer.lobes.size() == 1 ? p : p + ".components[" + std::to_string(j) + "]";
      if (auto e = check_spectrum(q + ".sigma_s", layer.lobes[j].sigma_s, false); !e.empty()) return e;
      for (int c = 0; c < kChannels; ++c) {
        const double g = layer.lobes[j].g[c];
        if (!std::isfinite(g) || std::abs(g) >= 1.0)
          return q + ".g[" + std::to_string(c) + "]: must satisfy |g| < 1";
      }
    }
    // Finite coefficients can still sum past the largest double: sigma_t = inf would make the
    // albedo sigma_s / sigma_t 0 or NaN, silently turning a scattering layer into a black one.
    for (int c = 0; c < kChannels; ++c)
      if (!std::isfinite(layer.sigma_t()[c])) {
        std::ostringstream os;
        os << p << ": sigma_a + sigma_s must be at most " << std::numeric_limits<double>::max()
           << " (the largest double; channel " << c << " overflows)";
        return os.str();
      }
  }
  if (stack.below.kind == Below::Kind::Dielectric) {
    if (auto e = check_ior("below.ior", stack.below.ior); !e.empty()) return e;
  } else {
    if (auto e = check_spectrum("below.lambert", stack.below.albedo, true); !e.empty()) return e;
  }
  // A single-scattering rough top on a transmitting stack would be a rough BOTTOM when the stack
  // is seen from behind (flipped), which that model does not have; the energy-conserving one
  // handles every interface from both sides.
  if (stack.top_roughness > 0.0 && stack.transmits() && stack.interface_model == InterfaceModel::SingleScattering)
    return "roughness: a rough top interface is only supported on stacks that do not transmit (a semi-infinite "
           "last layer or a lambert substrate) by the single-scattering model; \"interface_model\": "
           "\"energy_conserving\" supports any stack";
  return {};
}

}  // namespace lamina
