#include "renderer/layered/wavelength_stack.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "materials/stack/stack_file.h"

namespace lamina {
namespace {

// An RGB coefficient at the wavelengths: grey stays exactly grey (the basis sums to 1 only to
// the published data's 1e-5).
Spectrum uplifted_coefficient(const SampledWavelengths& w, const Spectrum& rgb) {
  return rgb.is_grey() ? rgb : w.reflectance(rgb);
}

// Whether a material file gives some layer by chromophores or leaf contents (the keys of
// docs/spectral.md); false for anything that is not such a JSON file.
bool gives_spectral_layers(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, false);
  if (!j.is_object() || !j.contains("layers") || !j["layers"].is_array()) return false;
  for (const nlohmann::json& layer : j["layers"])
    if (layer.is_object() && (layer.contains("chromophores") || layer.contains("leaf"))) return true;
  return false;
}

}  // namespace

void stack_at_wavelengths(const LayerStack& stack, const SpectralStack* chromophores, bool from_below,
                          const SampledWavelengths& w, LayerStack* out) {
  *out = stack;
  const std::size_t n = out->layers.size();
  for (std::size_t i = 0; i < n; ++i) {
    Layer& layer = out->layers[i];
    const std::size_t f = from_below ? n - 1 - i : i;  // the layer's index in the file
    const SkinChromophores* c =
        chromophores && f < chromophores->chromophores.size() && chromophores->chromophores[f] ? &*chromophores->chromophores[f]
                                                                                              : nullptr;
    const LeafChromophores* leaf = chromophores && f < chromophores->leaves.size() && chromophores->leaves[f] ? &*chromophores->leaves[f]
                                                                                                           : nullptr;
    if (c || leaf) {
      Spectrum sigma_s;
      for (int k = 0; k < kChannels; ++k) {
        layer.sigma_a[k] = c ? c->absorption(w.nm(k)) : leaf->absorption(w.nm(k), layer.thickness);
        sigma_s[k] = c ? c->scattering_coefficient(w.nm(k)) : leaf->scattering_coefficient(w.nm(k), layer.thickness);
      }
      layer.lobes.assign(1, PhaseLobe{sigma_s, Spectrum(c ? c->g : leaf->g)});
      continue;
    }
    layer.sigma_a = uplifted_coefficient(w, layer.sigma_a);
    for (PhaseLobe& lobe : layer.lobes) {
      lobe.sigma_s = uplifted_coefficient(w, lobe.sigma_s);
      lobe.g = uplifted_coefficient(w, lobe.g);
    }
  }
  if (out->below.kind == Below::Kind::Lambert) out->below.albedo = uplifted_coefficient(w, out->below.albedo);
}

void stack_at_wavelength_channel(const LayerStack& stack, const SpectralStack* chromophores, bool from_below,
                                 const SampledWavelengths& w, int channel, LayerStack* out) {
  stack_at_wavelengths(stack, chromophores, from_below, w, out);
  const std::size_t n = out->layers.size();
  for (std::size_t i = 0; i < n; ++i) {
    Layer& layer = out->layers[i];
    layer.sigma_a = Spectrum(layer.sigma_a[channel]);
    for (PhaseLobe& lobe : layer.lobes) lobe = PhaseLobe{Spectrum(lobe.sigma_s[channel]), Spectrum(lobe.g[channel])};
    const std::size_t f = from_below ? n - 1 - i : i;
    if (chromophores && f < chromophores->leaves.size() && chromophores->leaves[f])
      layer.ior = LeafChromophores::refractive_index(w.nm(channel));
  }
  if (out->below.kind == Below::Kind::Lambert) out->below.albedo = Spectrum(out->below.albedo[channel]);
}

bool has_leaf_layers(const SpectralStack& spectral) {
  for (const auto& leaf : spectral.leaves)
    if (leaf) return true;
  return false;
}

std::optional<StackTemplate> leaf_stack(const std::string& path) {
  if (!gives_spectral_layers(path)) return std::nullopt;
  try {
    StackTemplate t = load_spectral_stack_template(path);
    for (const LayerDesc& d : t.layers)
      if (d.leaf) return t;
  } catch (const StackFileError&) {
  }
  return std::nullopt;
}

void bind_chromophores(const SpectralStack& spectral, const StackBindings& bindings, glm::dvec2 uv,
                       SpectralStack* out) {
  *out = spectral;
  const std::vector<StackParameter>& ps = bindings.parameters();
  ParameterValues values(ps.size());
  bindings.values(uv, values.data());
  for (const StackParameter& p : ps) {
    if (p.layer < 0) continue;
    const auto l = static_cast<std::size_t>(p.layer);
    if (p.kind == StackParameter::Kind::kChromophore && l < out->chromophores.size() && out->chromophores[l])
      out->chromophores[l] = bound_chromophores(bindings.stack_template(), ps, values.data(), p.layer);
    if (p.kind == StackParameter::Kind::kLeaf && l < out->leaves.size() && out->leaves[l])
      out->leaves[l] = bound_leaf(bindings.stack_template(), ps, values.data(), p.layer);
  }
}

std::vector<std::shared_ptr<const SpectralStack>> spectral_stacks(const LayeredBindings& bindings) {
  std::vector<std::shared_ptr<const SpectralStack>> out(bindings.by_material.size());
  for (std::size_t m = 0; m < out.size(); ++m) {
    const LayeredMaterial* lm = bindings.by_material[m].get();
    if (!lm || !gives_spectral_layers(lm->source())) continue;
    out[m] = std::make_shared<SpectralStack>(load_spectral_stack(lm->source()));
  }
  return out;
}

}  // namespace lamina
