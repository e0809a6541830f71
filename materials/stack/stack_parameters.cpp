#include "materials/stack/stack_parameters.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <nlohmann/json.hpp>

#include "materials/stack/json_keys.h"

namespace lamina {

namespace {

using Kind = StackParameter::Kind;

// Largest |g| a parameter may take: the HG phase function is a delta at |g| = 1, which the
// model excludes (docs/contracts.md: |g| < 1).
constexpr double kMaxAbsG = 1.0 - 1e-6;

[[noreturn]] void fail(const std::string& path, const std::string& reason) {
  throw StackParameterError(path + ": " + reason);
}

// Reads "[n]" at s[pos...]; advances pos past it.
int read_index(const std::string& path, std::size_t* pos) {
  const std::string& s = path;
  if (*pos >= s.size() || s[*pos] != '[') fail(path, "expected '[' at character " + std::to_string(*pos + 1));
  const std::size_t close = s.find(']', *pos);
  if (close == std::string::npos) fail(path, "missing ']'");
  const std::string digits = s.substr(*pos + 1, close - *pos - 1);
  if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos)
    fail(path, "an index must be a non-negative integer, got '" + digits + "'");
  *pos = close + 1;
  return std::atoi(digits.c_str());
}

// The template's volume fractions of a chromophore layer other than `key` and the baseline (which
// gives way when a fraction is bound; apply_chromophores).
double other_volume_fractions(const SkinChromophores& c, const ChromophoreKey& key) {
  double sum = 0.0;
  for (const ChromophoreKey& k : chromophore_keys())
    if (k.volume_fraction && k.member != key.member && k.member != &SkinChromophores::baseline) sum += c.*k.member;
  return sum;
}

// layers[i].chromophores.KEY, `key` the text after "chromophores.".
StackParameter chromophore_parameter(const LayerDesc& desc, const std::string& key, StackParameter p) {
  const std::string layer = "layers[" + std::to_string(p.layer) + "]";
  if (!desc.chromophores) fail(p.path, layer + " is not given by chromophores");
  std::string names;
  for (std::size_t k = 0; k < chromophore_keys().size(); ++k) {
    const ChromophoreKey& ck = chromophore_keys()[k];
    names += std::string(k ? ", " : "") + ck.name;
    if (key != ck.name) continue;
    p.kind = Kind::kChromophore;
    p.chromophore = static_cast<int>(k);
    p.chromophore_max = ck.volume_fraction ? std::min(1.0, 1.0 - other_volume_fractions(*desc.chromophores, ck)) : ck.max;
    return p;
  }
  fail(p.path, "unknown chromophore key '" + key + "' (a texture can drive " + names + ")");
}

// Whether leaf key k is g, whose range is open (|g| < 1): its bound values stop at kMaxAbsG.
bool leaf_is_g(int k) { return leaf_keys()[k].own == &LeafChromophores::g; }

// layers[i].leaf.KEY, `key` the text after "leaf.".
StackParameter leaf_parameter(const LayerDesc& desc, const std::string& key, StackParameter p) {
  if (!desc.leaf) fail(p.path, "layers[" + std::to_string(p.layer) + "] is not given by leaf contents");
  for (std::size_t k = 0; k < leaf_keys().size(); ++k)
    if (key == leaf_keys()[k].name) {
      p.kind = Kind::kLeaf;
      p.leaf_key = static_cast<int>(k);
      return p;
    }
  fail(p.path, "unknown leaf key '" + key + "' (a texture can drive " + key_list(leaf_key_names()) + ")");
}

double clamp_value(Kind kind, double v) {
  if (std::isnan(v)) v = 0.0;
  switch (kind) {
    case Kind::kFraction:
    case Kind::kRoughness:
    case Kind::kBelowLambert: return std::clamp(v, 0.0, 1.0);
    case Kind::kG: return std::clamp(v, -kMaxAbsG, kMaxAbsG);
    case Kind::kIor:
    case Kind::kBelowIor: return std::clamp(v, 1e-6, std::numeric_limits<double>::max());
    default: return std::clamp(v, 0.0, std::numeric_limits<double>::max());
  }
}

Spectrum clamp_spectrum(Kind kind, const Spectrum& s) {
  return {clamp_value(kind, s[0]), clamp_value(kind, s[1]), clamp_value(kind, s[2])};
}

}  // namespace

bool StackParameter::spectral() const {
  return kind == Kind::kSigmaA || kind == Kind::kSigmaS || kind == Kind::kG || kind == Kind::kBelowLambert;
}

double StackParameter::min_value() const {
  switch (kind) {
    case Kind::kLeaf: return leaf_is_g(leaf_key) ? -kMaxAbsG : leaf_keys()[leaf_key].lo;
    case Kind::kG: return -kMaxAbsG;
    case Kind::kIor:
    case Kind::kBelowIor: return 1e-6;
    default: return 0.0;
  }
}

double StackParameter::max_value() const {
  switch (kind) {
    case Kind::kFraction:
    case Kind::kRoughness:
    case Kind::kBelowLambert: return 1.0;
    case Kind::kG: return kMaxAbsG;
    case Kind::kChromophore: return chromophore_max;
    case Kind::kLeaf: return leaf_is_g(leaf_key) ? kMaxAbsG : leaf_keys()[leaf_key].hi;
    default: return std::numeric_limits<double>::infinity();
  }
}

Spectrum StackParameter::template_value(const StackTemplate& t) const {
  switch (kind) {
    case Kind::kThickness: return Spectrum(t.stack.layers[layer].thickness);
    case Kind::kIor: return Spectrum(t.stack.layers[layer].ior);
    case Kind::kBelowLambert: return t.stack.below.albedo;
    case Kind::kBelowIor: return Spectrum(t.stack.below.ior);
    case Kind::kRoughness: return Spectrum(t.stack.top_roughness);
    case Kind::kChromophore: return Spectrum((*t.layers[layer].chromophores).*chromophore_keys()[chromophore].member);
    case Kind::kLeaf: return Spectrum(leaf_keys()[leaf_key].of(*t.layers[layer].leaf));
    default: break;
  }
  const ComponentDesc& c = t.layers[layer].components[component < 0 ? 0 : component];
  switch (kind) {
    case Kind::kFraction: return Spectrum(c.fraction);
    case Kind::kSigmaA: return c.sigma_a;
    case Kind::kSigmaS: return c.sigma_s;
    default: return c.g;
  }
}

StackParameter parse_stack_parameter(const StackTemplate& t, const std::string& path) {
  if (t.layers.size() != t.stack.layers.size()) fail(path, "internal: the template has no layer descriptions");
  StackParameter p;
  p.path = path;
  if (path == "below.lambert" || path == "below.ior") {
    const bool lambert = path == "below.lambert";
    if (lambert != (t.stack.below.kind == Below::Kind::Lambert))
      fail(path, std::string("the stack's \"below\" is ") +
                     (lambert ? "a dielectric ({\"ior\": n}), not a Lambert substrate"
                              : "a Lambert substrate, not a dielectric"));
    p.kind = lambert ? Kind::kBelowLambert : Kind::kBelowIor;
    return p;
  }
  if (path == "roughness") {
    // The top interface's GGX alpha; a single-scattering rough top needs a stack that does not
    // transmit (validate_stack).
    if (t.stack.transmits() && t.stack.interface_model == InterfaceModel::SingleScattering)
      fail(path, "a rough top interface is only supported on stacks that do not transmit (a semi-infinite last layer or a lambert substrate)");
    p.kind = Kind::kRoughness;
    return p;
  }
  const std::string prefix = "layers";
  if (path.compare(0, prefix.size(), prefix) != 0)
    fail(path, "expected roughness, or a path starting with layers[i] or below (e.g. layers[1].components[0].fraction)");
  std::size_t pos = prefix.size();
  p.layer = read_index(path, &pos);
  const int n = static_cast<int>(t.stack.layers.size());
  if (p.layer >= n)
    fail(path, "the stack has " + std::to_string(n) + " layer(s) (layers[0] .. layers[" + std::to_string(n - 1) + "])");
  const LayerDesc& desc = t.layers[p.layer];
  if (path.compare(pos, 14, ".chromophores.") == 0) return chromophore_parameter(desc, path.substr(pos + 14), p);
  if (path.compare(pos, 6, ".leaf.") == 0) return leaf_parameter(desc, path.substr(pos + 6), p);
  if (path.compare(pos, 12, ".components[") == 0) {
    if (!desc.composite) fail(path, "layers[" + std::to_string(p.layer) + "] has no components (it gives sigma_a, sigma_s, g)");
    pos += 11;
    p.component = read_index(path, &pos);
    const int m = static_cast<int>(desc.components.size());
    if (p.component >= m)
      fail(path, "layers[" + std::to_string(p.layer) + "] has " + std::to_string(m) + " component(s)");
  }
  if (pos >= path.size() || path[pos] != '.') fail(path, "expected '.' and a key after the index");
  const std::string key = path.substr(pos + 1);
  if (p.component >= 0) {
    if (key == "fraction") {
      if (desc.components.size() < 2) fail(path, "a layer's only component always has fraction 1");
      p.kind = Kind::kFraction;
    } else if (key == "sigma_a") p.kind = Kind::kSigmaA;
    else if (key == "sigma_s") p.kind = Kind::kSigmaS;
    else if (key == "g") p.kind = Kind::kG;
    else fail(path, "unknown key '" + key + "' (a component has fraction, sigma_a, sigma_s, g)");
    return p;
  }
  if (key == "thickness") {
    if (t.stack.layers[p.layer].semi_infinite()) fail(path, "the layer is semi-infinite (\"inf\"); its thickness cannot be bound");
    p.kind = Kind::kThickness;
  } else if (desc.leaf) {
    // The spectral mode evaluates a leaf layer from its contents, its index PROSPECT-D's.
    fail(path, "layers[" + std::to_string(p.layer) + "] is given by leaf contents: bind layers[" + std::to_string(p.layer) +
                   "].leaf.KEY");
  } else if (key == "ior") {
    p.kind = Kind::kIor;
  } else if (key == "sigma_a" || key == "sigma_s" || key == "g") {
    if (desc.chromophores)
      fail(path, "layers[" + std::to_string(p.layer) + "] is given by chromophores: bind layers[" +
                     std::to_string(p.layer) + "].chromophores.KEY");
    if (desc.composite)
      fail(path, "layers[" + std::to_string(p.layer) + "] is mixed from components: bind layers[" +
                     std::to_string(p.layer) + "].components[j]." + key);
    p.kind = key == "sigma_a" ? Kind::kSigmaA : key == "sigma_s" ? Kind::kSigmaS : Kind::kG;
  } else {
    fail(path, "unknown key '" + key + "' (a layer has thickness, ior, sigma_a, sigma_s, g, components[j], chromophores.KEY)");
  }
  return p;
}

void check_parameter_set(const std::vector<StackParameter>& ps) {
  for (std::size_t a = 0; a < ps.size(); ++a)
    for (std::size_t b = 0; b < a; ++b) {
      if (ps[a].kind == ps[b].kind && ps[a].layer == ps[b].layer && ps[a].component == ps[b].component &&
          ps[a].chromophore == ps[b].chromophore && ps[a].leaf_key == ps[b].leaf_key)
        fail(ps[a].path, "bound twice (also as '" + ps[b].path + "')");
      if (ps[a].kind == Kind::kChromophore && ps[b].kind == Kind::kChromophore && ps[a].layer == ps[b].layer &&
          chromophore_keys()[ps[a].chromophore].volume_fraction && chromophore_keys()[ps[b].chromophore].volume_fraction)
        fail(ps[a].path, "only one volume fraction per chromophore layer can be bound (also '" + ps[b].path +
                             "'): the baseline gives way to keep the sum at most 1");
      if (ps[a].kind == Kind::kFraction && ps[b].kind == Kind::kFraction && ps[a].layer == ps[b].layer)
        fail(ps[a].path, "only one fraction per layer can be bound (also '" + ps[b].path +
                             "'): the others are rescaled to keep the sum 1");
    }
}

void mix_layer(const LayerDesc& desc, Layer* layer) {
  layer->sigma_a = Spectrum(0.0);
  layer->lobes.resize(desc.components.size());
  for (std::size_t k = 0; k < desc.components.size(); ++k) {
    const ComponentDesc& c = desc.components[k];
    layer->sigma_a += c.fraction * c.sigma_a;
    layer->lobes[k] = PhaseLobe{c.fraction * c.sigma_s, c.g};
  }
}

// A chromophore layer with the chromophores bound in it set. A bound volume fraction x takes its
// difference from the template's x0 out of the baseline, b = max(0, b0 - (x - x0)), as Donner
// and Jensen's bloodless tissue fills what melanin and blood leave.
SkinChromophores bound_chromophores(const StackTemplate& t, const std::vector<StackParameter>& ps,
                                    const Spectrum* values, int l) {
  const SkinChromophores& c0 = *t.layers[l].chromophores;
  SkinChromophores c = c0;
  for (std::size_t e = 0; e < ps.size(); ++e) {
    const StackParameter& p = ps[e];
    if (p.layer != l || p.kind != Kind::kChromophore) continue;
    const ChromophoreKey& key = chromophore_keys()[p.chromophore];
    const double x = std::clamp(clamp_value(p.kind, values[e][0]), 0.0, p.chromophore_max);
    c.*key.member = x;
    if (key.volume_fraction && key.member != &SkinChromophores::baseline)
      c.baseline = std::max(0.0, c0.baseline - (x - c0.*key.member));
  }
  return c;
}

LeafChromophores bound_leaf(const StackTemplate& t, const std::vector<StackParameter>& ps, const Spectrum* values,
                            int l) {
  LeafChromophores c = *t.layers[l].leaf;
  for (std::size_t e = 0; e < ps.size(); ++e) {
    const StackParameter& p = ps[e];
    if (p.layer != l || p.kind != Kind::kLeaf) continue;
    const double v = std::isnan(values[e][0]) ? 0.0 : values[e][0];
    leaf_keys()[p.leaf_key].of(c) = std::clamp(v, p.min_value(), p.max_value());
  }
  return c;
}

namespace {

// ps[first] the first parameter naming the layer: its RGB absorption recomputed as the file
// reader computes it (the same function of the same numbers, so a map holding the file's value
// gives the file's stack bit for bit).
void apply_chromophores(const StackTemplate& t, const std::vector<StackParameter>& ps, const Spectrum* values,
                        std::size_t first, LayerStack* out) {
  const int l = ps[first].layer;
  for (std::size_t e = 0; e < first; ++e)
    if (ps[e].layer == l && ps[e].kind == Kind::kChromophore) return;  // done with the first
  out->layers[l].sigma_a = bound_chromophores(t, ps, values, l).absorption_rgb();
}

}  // namespace

void apply_parameters(const StackTemplate& t, const std::vector<StackParameter>& ps, const Spectrum* values,
                      LayerStack* out) {
  *out = t.stack;  // copy-assignment reuses out's vectors and strings when their capacity suffices
  for (std::size_t k = 0; k < ps.size(); ++k) {
    const StackParameter& p = ps[k];
    const Spectrum v = clamp_spectrum(p.kind, values[k]);
    switch (p.kind) {
      case Kind::kThickness: out->layers[p.layer].thickness = v[0]; break;
      case Kind::kIor: out->layers[p.layer].ior = v[0]; break;
      case Kind::kBelowLambert: out->below.albedo = v; break;
      case Kind::kBelowIor: out->below.ior = v[0]; break;
      case Kind::kRoughness: out->top_roughness = v[0]; break;
      default: break;  // composition parameters: re-mixed below
    }
  }
  // Re-mix each layer that has a composition parameter, once (the first parameter naming it).
  for (std::size_t k = 0; k < ps.size(); ++k) {
    const int l = ps[k].layer;
    // A leaf layer's contents are read per wavelength (bound_leaf); its placeholders stay.
    if (l < 0 || ps[k].kind == Kind::kThickness || ps[k].kind == Kind::kIor || ps[k].kind == Kind::kLeaf) continue;
    if (ps[k].kind == Kind::kChromophore) {
      apply_chromophores(t, ps, values, k, out);
      continue;
    }
    bool seen = false;
    for (std::size_t e = 0; e < k && !seen; ++e)
      seen = ps[e].layer == l && ps[e].kind != Kind::kThickness && ps[e].kind != Kind::kIor;
    if (seen) continue;

    const LayerDesc& d = t.layers[l];
    const int m = static_cast<int>(d.components.size());
    int fj = -1;
    double f = 0.0;
    for (std::size_t e = 0; e < ps.size(); ++e)
      if (ps[e].layer == l && ps[e].kind == Kind::kFraction) {
        fj = ps[e].component;
        f = clamp_value(Kind::kFraction, values[e][0]);
      }
    double rest = 0.0;  // the template's total fraction of the other components
    if (fj >= 0)
      for (int j = 0; j < m; ++j)
        if (j != fj) rest += d.components[j].fraction;

    Layer& layer = out->layers[l];
    layer.sigma_a = Spectrum(0.0);
    for (int j = 0; j < m; ++j) {
      const ComponentDesc& c = d.components[j];
      double w = c.fraction;
      if (fj >= 0) w = j == fj ? f : (rest > 0.0 ? w * (1.0 - f) / rest : (1.0 - f) / (m - 1));
      Spectrum sa = c.sigma_a, ss = c.sigma_s, g = c.g;
      for (std::size_t e = 0; e < ps.size(); ++e) {
        const StackParameter& p = ps[e];
        if (p.layer != l || !(p.component == j || (p.component < 0 && !d.composite))) continue;
        if (p.kind == Kind::kSigmaA) sa = clamp_spectrum(p.kind, values[e]);
        if (p.kind == Kind::kSigmaS) ss = clamp_spectrum(p.kind, values[e]);
        if (p.kind == Kind::kG) g = clamp_spectrum(p.kind, values[e]);
      }
      if (d.composite) {
        layer.sigma_a += w * sa;
        layer.lobes[j] = PhaseLobe{w * ss, g};
      } else {  // a direct layer: its values as given (the file reader stores them unscaled)
        layer.sigma_a = sa;
        layer.lobes[j] = PhaseLobe{ss, g};
      }
    }
  }
}

std::vector<StackPathStep> split_stack_path(const std::string& path) {
  std::vector<StackPathStep> steps;
  std::size_t i = 0;
  // After a key or an index: a '.' must be followed by something.
  auto skip_dot = [&] {
    if (i < path.size() && path[i] == '.') {
      ++i;
      if (i == path.size()) fail(path, "nothing after the last '.'");
    }
  };
  while (i < path.size()) {
    if (path[i] == '[') {
      // The index syntax of parse_stack_parameter: the same reader, so the two agree.
      steps.push_back({"", static_cast<std::size_t>(read_index(path, &i))});
    } else {
      std::size_t end = path.find_first_of(".[", i);
      if (end == std::string::npos) end = path.size();
      if (end == i) fail(path, "expected a key at character " + std::to_string(i + 1));
      steps.push_back({path.substr(i, end - i), 0});
      i = end;
    }
    skip_dot();
  }
  if (steps.empty()) fail(path, "empty path");
  return steps;
}

nlohmann::json* find_stack_value(nlohmann::json& stack, const std::vector<StackPathStep>& steps, const std::string& path) {
  auto no = [&](const std::string& reason) { throw StackParameterError("'" + path + "': " + reason); };
  nlohmann::json* node = &stack;
  std::string walked;  // the steps taken so far, as a path
  for (const StackPathStep& s : steps) {
    if (s.key.empty()) {
      if (!node->is_array()) no("'" + walked + "' is not an array");
      if (s.index >= node->size())
        no("'" + walked + "' has " + std::to_string(node->size()) + " entries, no [" + std::to_string(s.index) + "]");
      node = &(*node)[s.index];
      walked += "[" + std::to_string(s.index) + "]";
    } else {
      walked += (walked.empty() ? "" : ".") + s.key;
      if (!node->is_object() || !node->contains(s.key)) no("the stack has no '" + walked + "'");
      node = &(*node)[s.key];
    }
  }
  return node;
}

}  // namespace lamina
