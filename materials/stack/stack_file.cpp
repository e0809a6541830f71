#include "materials/stack/stack_file.h"
#include "materials/stack/json_keys.h"
#include "materials/stack/json_limits.h"
#include "materials/stack/text_file.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <utility>
#include <vector>
#include <sstream>

#include <nlohmann/json.hpp>

namespace lamina {

namespace {

using nlohmann::json;

// Reads one JSON document and throws StackFileError("SOURCE: PATH: reason") on any problem.
class Reader {
 public:
  // With `spectral`, layers may be given by chromophores (one entry per layer is written there);
  // without it such a layer is an error.
  // With `leaves` too (the same reader's spectral mode), layers may be given by leaf contents.
  explicit Reader(std::string source, std::vector<std::optional<SkinChromophores>>* spectral = nullptr,
                  std::vector<std::optional<LeafChromophores>>* leaves = nullptr)
      : source_(std::move(source)), spectral_(spectral), leaves_(leaves) {}

  [[noreturn]] void fail(const std::string& path, const std::string& reason) const {
    throw StackFileError(source_ + ": " + (path.empty() ? std::string("(document)") : path) +
                         ": " + reason);
  }

  static std::string type_name(const json& j) {
    if (j.is_string()) return "a string";
    if (j.is_number()) return "a number";
    if (j.is_boolean()) return "a boolean";
    if (j.is_null()) return "null";
    if (j.is_array()) return "an array";
    return "an object";
  }

  static std::string fmt(double v) {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
  }

  void require_object(const json& j, const std::string& path) const {
    if (!j.is_object()) fail(path, "expected an object, got " + type_name(j));
  }

  // Rejects keys outside `allowed` (a misspelt key must not be ignored).
  void check_keys(const json& j, const std::string& path,
                  std::initializer_list<const char*> allowed) const {
    if (const std::string* key = first_unknown_key(j, allowed))
      fail(join(path, *key), "unknown key (allowed here: " + key_list(allowed) + ")");
  }

  const json& member(const json& j, const std::string& path, const char* key) const {
    auto it = j.find(key);
    if (it == j.end()) fail(join(path, key), "missing required key");
    return *it;
  }

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

  bool boolean(const json& j, const std::string& path) const {
    if (!j.is_boolean()) fail(path, "expected a boolean (true or false), got " + type_name(j));
    return j.get<bool>();
  }

  // A finite number.
  double number(const json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, "expected a number, got " + type_name(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, "must be finite");
    return v;
  }

  // A colour: a number (grey) or [r, g, b]. Each channel passes `check` (which calls fail).
  template <typename Check>
  Spectrum colour(const json& j, const std::string& path, Check check) const {
    Spectrum s;
    if (j.is_number()) {
      s = Spectrum(number(j, path));
      check(s[0], path);
    } else if (j.is_array()) {
      if (j.size() != kChannels)
        fail(path, "expected a number or an array of 3 numbers [r, g, b], got an array of " +
                       std::to_string(j.size()));
      for (int c = 0; c < kChannels; ++c) {
        const std::string p = path + "[" + std::to_string(c) + "]";
        s[c] = number(j[c], p);
        check(s[c], p);
      }
    } else {
      fail(path, "expected a number or [r, g, b], got " + type_name(j));
    }
    return s;
  }

  Spectrum coefficient(const json& j, const std::string& path) const {
    return colour(j, path, [this](double v, const std::string& p) {
      if (v < 0.0) fail(p, "coefficients must be >= 0 (got " + fmt(v) + ")");
    });
  }

  Spectrum asymmetry(const json& j, const std::string& path) const {
    return colour(j, path, [this](double v, const std::string& p) {
      if (!(std::abs(v) < 1.0))
        fail(p, "Henyey-Greenstein g must satisfy |g| < 1 (got " + fmt(v) + ")");
    });
  }

  double ior(const json& j, const std::string& path) const {
    const double n = number(j, path);
    if (n <= 0.0) fail(path, "index of refraction must be > 0 (got " + fmt(n) + ")");
    return n;
  }

  std::string string(const json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, "expected a string, got " + type_name(j));
    return j.get<std::string>();
  }

  // A number in [lo, hi].
  double bounded(const json& j, const std::string& path, double lo, double hi) const {
    const double v = number(j, path);
    if (v < lo || v > hi) fail(path, "must lie in [" + fmt(lo) + ", " + fmt(hi) + "] (got " + fmt(v) + ")");
    return v;
  }

  // A layer's "chromophores" object (docs/spectral.md, "Skin chromophores"); every key optional.
  SkinChromophores chromophores(const json& j, const std::string& path) const {
    require_object(j, path);
    check_keys(j, path, {"melanin", "eumelanin", "blood", "oxygenation", "water", "fat", "carotene", "baseline",
                         "scattering", "g"});
    SkinChromophores c;
    const double inf = std::numeric_limits<double>::infinity();
    double sum = 0.0;  // of the volume fractions
    for (const ChromophoreKey& key : chromophore_keys()) {
      if (!j.contains(key.name)) continue;
      const double v = c.*key.member = bounded(j[key.name], join(path, key.name), 0.0, key.max);
      if (key.volume_fraction) sum += v;
    }
    if (sum > 1.0 + 1e-9)
      fail(path, "volume fractions melanin + blood + water + fat + baseline must not exceed 1 (sum " + fmt(sum) + ")");
    if (j.contains("g")) {
      if (!j["g"].is_number()) fail(join(path, "g"), "expected a number (one g at every wavelength), got " + type_name(j["g"]));
      c.g = asymmetry(j["g"], join(path, "g"))[0];
    }
    if (j.contains("scattering")) {
      const json& sc = j["scattering"];
      const std::string sp = join(path, "scattering");
      require_object(sc, sp);
      check_keys(sc, sp, {"reduced_500", "f_rayleigh", "b_mie"});
      c.scattering.reduced_500 = bounded(member(sc, sp, "reduced_500"), join(sp, "reduced_500"), 0.0, inf);
      if (sc.contains("f_rayleigh")) c.scattering.f_rayleigh = bounded(sc["f_rayleigh"], join(sp, "f_rayleigh"), 0.0, 1.0);
      if (sc.contains("b_mie")) c.scattering.b_mie = bounded(sc["b_mie"], join(sp, "b_mie"), 0.0, 10.0);
    }
    return c;
  }

  // A layer's "leaf" object (docs/spectral.md, "Layered leaf"): the keys of leaf_keys() (contents
  // per leaf area, "plates", "scattering_power" and "g"); every key optional.
  LeafChromophores leaf(const json& j, const std::string& path) const {
    require_object(j, path);
    if (const std::string* key = first_unknown_key(j, leaf_key_names()))
      fail(join(path, *key), "unknown key (allowed here: " + key_list(leaf_key_names()) + ")");
    LeafChromophores c;
    for (const LeafKey& k : leaf_keys())
      if (j.contains(k.name) && k.own != &LeafChromophores::g) k.of(c) = bounded(j[k.name], join(path, k.name), k.lo, k.hi);
    if (j.contains("g")) {
      if (!j["g"].is_number()) fail(join(path, "g"), "expected a number (one g at every wavelength), got " + type_name(j["g"]));
      c.g = asymmetry(j["g"], join(path, "g"))[0];
    }
    return c;
  }

  static bool grey(const Layer& layer) {
    if (!layer.sigma_a.is_grey()) return false;
    for (const PhaseLobe& lobe : layer.lobes)
      if (!lobe.sigma_s.is_grey() || !lobe.g.is_grey()) return false;
    return true;
  }

  Layer layer(const json& j, const std::string& path, bool last, LayerDesc* desc,
              std::optional<SkinChromophores>* spectral, std::optional<LeafChromophores>* leaf_out = nullptr) const {
    require_object(j, path);
    check_keys(j, path, {"name", "ior", "thickness", "bottom_roughness", "bottom_diffuse", "sigma_a", "sigma_s", "g", "components",
                         "chromophores", "leaf"});
    Layer layer;
    if (j.contains("name")) layer.name = string(j["name"], join(path, "name"));
    const bool is_leaf = j.contains("leaf");
    if (is_leaf && j.contains("ior"))
      fail(join(path, "ior"), "a leaf layer's index is PROSPECT-D's at each wavelength: leave out ior");
    // A leaf layer's placeholder index: PROSPECT-D's at 550 nm (stack_at_wavelength sets each).
    layer.ior = is_leaf ? LeafChromophores::refractive_index(550.0) : ior(member(j, path, "ior"), join(path, "ior"));
    if (j.contains("bottom_roughness")) layer.bottom_roughness = number(j["bottom_roughness"], join(path, "bottom_roughness"));
    if (j.contains("bottom_diffuse")) layer.bottom_diffuse = boolean(j["bottom_diffuse"], join(path, "bottom_diffuse"));

    const json& t = member(j, path, "thickness");
    const std::string tp = join(path, "thickness");
    if (t.is_string()) {
      if (t.get<std::string>() != "inf")
        fail(tp, "expected a number >= 0 or the string \"inf\", got \"" + t.get<std::string>() + "\"");
      if (!last) fail(tp, "only the last layer may be semi-infinite (\"inf\")");
      layer.thickness = kInfiniteThickness;
    } else {
      layer.thickness = number(t, tp);
      if (layer.thickness < 0.0) fail(tp, "thickness must be >= 0 (got " + fmt(layer.thickness) + ")");
    }

    const bool direct = j.contains("sigma_a") || j.contains("sigma_s") || j.contains("g");
    if (is_leaf) {
      if (direct || j.contains("components") || j.contains("chromophores"))
        fail(path, "give either leaf, or chromophores, or sigma_a, sigma_s and g, or components, not two of them");
      if (leaf_out == nullptr)
        fail(join(path, "leaf"), "a layer given by leaf contents has spectral coefficients: it is read by "
                                 "`lamina render --spectral`, `lamina brdf --wavelengths` and `lamina fit --spectrum`");
      if (!(layer.thickness > 0.0) || layer.thickness == kInfiniteThickness)
        fail(join(path, "thickness"), "a leaf layer needs a finite thickness > 0 (its contents are per leaf area)");
      *leaf_out = desc->leaf = leaf(j["leaf"], join(path, "leaf"));
      const LeafChromophores& c = **leaf_out;  // placeholders at 550 nm, as for chromophores below
      layer.sigma_a = Spectrum(c.absorption(550.0, layer.thickness));
      layer.lobes.push_back({Spectrum(c.scattering_coefficient(550.0, layer.thickness)), Spectrum(c.g)});
      desc->components.push_back({1.0, layer.sigma_a, layer.lobes.back().sigma_s, Spectrum(c.g)});
      return layer;
    }
    if (j.contains("chromophores")) {
      if (direct || j.contains("components"))
        fail(path, "give either chromophores, or sigma_a, sigma_s and g, or components, not two of them");
      const SkinChromophores c = chromophores(j["chromophores"], join(path, "chromophores"));
      if (spectral) {
        // Placeholders, the coefficients at 550 nm (so that validate_stack checks real values): the
        // coefficients come per wavelength (stack_at_wavelength).
        *spectral = c;
        layer.sigma_a = Spectrum(c.absorption(550.0));
        layer.lobes.push_back({Spectrum(c.scattering_coefficient(550.0)), Spectrum(c.g)});
      } else {
        // The RGB mode: each channel's mean of the spectra (SkinChromophores::absorption_rgb; a
        // bound chromophore recomputes it the same way, apply_parameters).
        layer.sigma_a = c.absorption_rgb();
        layer.lobes.push_back({c.scattering_coefficient_rgb(), Spectrum(c.g)});
      }
      desc->chromophores = c;
      desc->components.push_back({1.0, layer.sigma_a, layer.lobes.back().sigma_s, Spectrum(c.g)});
      return layer;
    }
    if (j.contains("components")) {
      if (direct)
        fail(path, "give either sigma_a, sigma_s and g, or components, not both");
      desc->composite = true;
      const json& comps = j["components"];
      const std::string cp = join(path, "components");
      if (!comps.is_array()) fail(cp, "expected an array of components, got " + type_name(comps));
      if (comps.empty()) fail(cp, "a layer needs at least one component");
      // Volume fractions w_i: sigma_a = sum w_i sigma_a_i and sigma_s p = sum w_i sigma_s_i
      // p_HG(g_i) (docs/contracts.md; Hanrahan and Krueger eq. 8). Each component is one lobe.
      double sum = 0.0;
      for (std::size_t i = 0; i < comps.size(); ++i) {
        const json& c = comps[i];
        const std::string p = cp + "[" + std::to_string(i) + "]";
        require_object(c, p);
        check_keys(c, p, {"name", "fraction", "sigma_a", "sigma_s", "g"});
        if (c.contains("name")) string(c["name"], join(p, "name"));
        const double w = number(member(c, p, "fraction"), join(p, "fraction"));
        if (w < 0.0) fail(join(p, "fraction"), "fractions must be >= 0 (got " + fmt(w) + ")");
        const Spectrum sa = coefficient(member(c, p, "sigma_a"), join(p, "sigma_a"));
        const Spectrum ss = coefficient(member(c, p, "sigma_s"), join(p, "sigma_s"));
        const Spectrum g = asymmetry(member(c, p, "g"), join(p, "g"));
        layer.sigma_a += w * sa;
        layer.lobes.push_back({w * ss, g});
        desc->components.push_back({w, sa, ss, g});
        sum += w;
      }
      if (std::abs(sum - 1.0) > 1e-6) {
        // Name the last fraction: that is where the running sum is known to be wrong.
        fail(cp + "[" + std::to_string(comps.size() - 1) + "].fraction",
             "fractions must sum to 1 (sum " + fmt(sum) + ")");
      }
    } else {
      const Spectrum sa = coefficient(member(j, path, "sigma_a"), join(path, "sigma_a"));
      const Spectrum ss = coefficient(member(j, path, "sigma_s"), join(path, "sigma_s"));
      const Spectrum g = asymmetry(member(j, path, "g"), join(path, "g"));
      layer.sigma_a = sa;
      layer.lobes.push_back({ss, g});
      desc->components.push_back({1.0, sa, ss, g});
    }
    return layer;
  }

  InterfaceModel interface_model(const json& j) const {
    const std::string name = string(j, "interface_model");
    if (name == "single_scattering") return InterfaceModel::SingleScattering;
    if (name == "energy_conserving") return InterfaceModel::EnergyConserving;
    fail("interface_model", "expected \"energy_conserving\" or \"single_scattering\" (got \"" + name + "\")");
  }

  Below below(const json& j, const std::string& path) const {
    require_object(j, path);
    check_keys(j, path, {"ior", "lambert"});
    Below b;
    if (j.contains("ior") && j.contains("lambert"))
      fail(path, "give either \"ior\" or \"lambert\", not both");
    if (j.contains("ior")) {
      b.kind = Below::Kind::Dielectric;
      b.ior = ior(j["ior"], join(path, "ior"));
    } else if (j.contains("lambert")) {
      b.kind = Below::Kind::Lambert;
      b.albedo = colour(j["lambert"], join(path, "lambert"), [this](double v, const std::string& p) {
        if (v < 0.0 || v > 1.0) fail(p, "Lambert albedo must lie in [0, 1] (got " + fmt(v) + ")");
      });
    } else {
      fail(path, "expected {\"ior\": n} or {\"lambert\": albedo}");
    }
    return b;
  }

  StackTemplate stack(const json& root) const {
    require_object(root, "");
    check_keys(root, "", {"lamina_material", "name", "above_ior", "roughness", "top_diffuse", "interface_model", "layers",
                             "below"});
    const json& version = member(root, "", "lamina_material");
    if (!version.is_number() || version.get<double>() != 1.0)
      fail("lamina_material", "unsupported version " + version.dump() + " (this build reads version 1)");

    StackTemplate t;
    LayerStack& s = t.stack;
    if (root.contains("name")) s.name = string(root["name"], "name");
    if (root.contains("above_ior")) s.above_ior = ior(root["above_ior"], "above_ior");
    if (root.contains("roughness")) s.top_roughness = number(root["roughness"], "roughness");
    if (root.contains("top_diffuse")) s.top_diffuse = boolean(root["top_diffuse"], "top_diffuse");
    if (root.contains("interface_model")) s.interface_model = interface_model(root["interface_model"]);
    const json& layers = member(root, "", "layers");
    if (!layers.is_array()) fail("layers", "expected an array of layers, got " + type_name(layers));
    if (layers.empty()) fail("layers", "a stack needs at least one layer");
    t.layers.resize(layers.size());
    if (spectral_) spectral_->assign(layers.size(), std::nullopt);
    if (leaves_) leaves_->assign(layers.size(), std::nullopt);
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const std::string path = "layers[" + std::to_string(i) + "]";
      s.layers.push_back(layer(layers[i], path, i + 1 == layers.size(), &t.layers[i], spectral_ ? &(*spectral_)[i] : nullptr,
                               leaves_ ? &(*leaves_)[i] : nullptr));
      // A spectral stack's other layers must be the same at every wavelength.
      if (spectral_ && !(*spectral_)[i] && !(leaves_ && (*leaves_)[i]) && !grey(s.layers.back()))
        fail(path, "in a stack with chromophore layers every other layer must be grey (one number per coefficient)");
    }
    if (root.contains("below")) s.below = below(root["below"], "below");
    if (spectral_ && s.below.kind == Below::Kind::Lambert && !s.below.albedo.is_grey())
      fail("below.lambert", "in a stack with chromophore layers the substrate's albedo must be grey (one number)");

    // The model's own invariants, in case the checks above and validate_stack() ever diverge.
    const std::string problem = validate_stack(s);
    if (!problem.empty()) throw StackFileError(source_ + ": " + problem);
    return t;
  }

 private:
  std::string source_;
  std::vector<std::optional<SkinChromophores>>* spectral_ = nullptr;
  std::vector<std::optional<LeafChromophores>>* leaves_ = nullptr;
};

}  // namespace

namespace {

StackTemplate parse(const std::string& text, const std::string& source_name,
                    std::vector<std::optional<SkinChromophores>>* spectral,
                    std::vector<std::optional<LeafChromophores>>* leaves = nullptr) {
  Reader reader(source_name, spectral, leaves);
  // Before parsing: JSON nested deeper than any material file would overflow the stack of the
  // recursive walks over it (materials/stack/json_limits.h).
  if (const auto deep = json_nesting_exceeds(text)) throw StackFileError(source_name + ": " + json_nesting_message(*deep));
  json root;
  std::string where;
  const std::string why = parse_json_text(text, &root, &where);
  if (!why.empty()) reader.fail(where, why);
  return reader.stack(root);
}

std::string read_material_file(const std::string& path) {
  std::string text;
  const std::string why = read_text_file(path, &text);  // materials/stack/text_file.h: says why
  if (!why.empty()) throw StackFileError(path + ": cannot read the material file: " + why);
  return text;
}

}  // namespace

StackTemplate parse_stack_template_json(const std::string& text, const std::string& source_name) {
  return parse(text, source_name, nullptr);
}

StackTemplate load_stack_template(const std::string& path) { return parse_stack_template_json(read_material_file(path), path); }

SpectralStack parse_spectral_stack_json(const std::string& text, const std::string& source_name) {
  SpectralStack s;
  s.stack = parse(text, source_name, &s.chromophores, &s.leaves).stack;
  return s;
}

SpectralStack load_spectral_stack(const std::string& path) { return parse_spectral_stack_json(read_material_file(path), path); }

StackTemplate load_spectral_stack_template(const std::string& path) {
  SpectralStack s;
  return parse(read_material_file(path), path, &s.chromophores, &s.leaves);
}

LayerStack parse_stack_json(const std::string& text, const std::string& source_name) {
  return parse_stack_template_json(text, source_name).stack;
}

LayerStack load_stack_file(const std::string& path) { return load_stack_template(path).stack; }

}  // namespace lamina
