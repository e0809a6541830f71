#include "renderer/layered/layered_material.h"

#include <algorithm>
#include <sstream>

#include "materials/tables/albedo.h"
#include "materials/stack/stack_parameters.h"
#include "renderer/layered/stack_bindings.h"

namespace lamina {
namespace {

// The lambert mode's albedo of a stack: by adding-doubling, rough interfaces (single-scattering
// top or energy-conserving anywhere) projected onto its basis (no noise: standard error 0;
// materials/tables/albedo.h). `walks` is no longer used by any stack.
Spectrum albedo_of(const LayerStack& stack, int /*walks*/, Spectrum* standard_error = nullptr) {
  if (standard_error) *standard_error = Spectrum(0.0);
  return diffuse_bihemispherical_albedo_adding_doubling(stack);
}

}  // namespace

LayeredMaterial::LayeredMaterial(LayerStack stack, std::string source, int albedo_walks)
    : stack_(std::move(stack)), source_(std::move(source)), albedo_walks_(albedo_walks) {
  if (stack_.transmits()) flipped_ = flipped(stack_);
}

const Spectrum& LayeredMaterial::lambert_albedo() const {
  // Computed once per material, on first use.
  std::call_once(albedo_once_, [this] {
    lambert_albedo_ = albedo_of(stack_, albedo_walks_, &lambert_albedo_stderr_);
    albedo_state_ = 1;
  });
  return lambert_albedo_;
}

bool LayeredMaterial::preset_lambert_albedo(const Spectrum& albedo, const Spectrum& standard_error) const {
  bool set = false;
  std::call_once(albedo_once_, [&] {
    lambert_albedo_ = albedo;
    lambert_albedo_stderr_ = standard_error;
    albedo_state_ = 2;
    set = true;
  });
  return set;
}

const Spectrum& LayeredMaterial::lambert_albedo_stderr() const {
  lambert_albedo();
  return lambert_albedo_stderr_;
}

LayeredMaterial::LayeredMaterial(LayerStack stack, std::string source, std::shared_ptr<const StackBindings> bindings)
    : LayeredMaterial(std::move(stack), std::move(source)) {
  if (bindings && !bindings->empty()) bindings_ = std::move(bindings);
}

Spectrum LayeredMaterial::lambert_albedo_at(glm::dvec2 uv) const {
  const Spectrum& base = lambert_albedo();
  if (!bindings_) return base;
  const std::vector<StackParameter>& ps = bindings_->parameters();
  std::call_once(factors_once_, [&] {
    const StackTemplate& t = bindings_->stack_template();
    std::vector<Spectrum> values(ps.size());
    for (std::size_t k = 0; k < ps.size(); ++k) values[k] = ps[k].template_value(t);
    LayerStack stack;
    apply_parameters(t, ps, values.data(), &stack);
    const Spectrum a_template = albedo_of(stack, kLambertNodeWalks);
    factors_.resize(ps.size());
    // A parameter its map holds constant has one node: its value goes into the base values, the
    // others' ratios are taken there, and constant_factor_ carries it.
    bool constant = false;
    for (std::size_t k = 0; k < ps.size(); ++k) {
      factors_[k].nodes = bindings_->nodes(k, kLambertNodes);
      if (factors_[k].nodes.values.size() == 1) {
        values[k] = factors_[k].nodes.values[0];
        constant = true;
      }
    }
    Spectrum a0 = a_template;
    if (constant) {
      apply_parameters(t, ps, values.data(), &stack);
      a0 = albedo_of(stack, kLambertNodeWalks);
      for (int c = 0; c < kChannels; ++c) constant_factor_[c] = a_template[c] > 0.0 ? a0[c] / a_template[c] : 1.0;
    }
    for (std::size_t k = 0; k < ps.size(); ++k) {
      AlbedoFactor& f = factors_[k];
      if (f.nodes.values.size() < 2) continue;
      std::vector<Spectrum> v = values;
      for (const Spectrum& node : f.nodes.values) {
        v[k] = node;
        apply_parameters(t, ps, v.data(), &stack);
        const Spectrum a = albedo_of(stack, kLambertNodeWalks);
        Spectrum r;
        for (int c = 0; c < kChannels; ++c) r[c] = a0[c] > 0.0 ? a[c] / a0[c] : 1.0;
        f.ratio.push_back(r);
      }
    }
  });
  ParameterValues values(ps.size());
  Spectrum* v = values.data();
  bindings_->values(uv, v);
  Spectrum albedo = base * constant_factor_;
  for (std::size_t k = 0; k < factors_.size(); ++k) {
    const AlbedoFactor& f = factors_[k];
    if (f.nodes.values.size() < 2) continue;  // in constant_factor_
    std::size_t j = 0;
    double w = 0.0;
    f.nodes.bracket(v[k][f.nodes.channel], &j, &w);
    albedo *= f.ratio[j] * (1.0 - w) + f.ratio[j + 1] * w;
  }
  for (int c = 0; c < kChannels; ++c) albedo[c] = std::clamp(albedo[c], 0.0, 1.0);
  return albedo;
}

const LayerStack& LayeredMaterial::stack_at(const ShadingPoint& sp, StackScratch& scratch) const {
  if (bindings_) {
    // Texture-driven parameters: the stack at this uv, built in the caller's scratch (no
    // allocation once its vectors have grown; stack_bindings.h).
    bindings_->evaluate(sp.uv, &scratch.stack);
    if (!(sp.from_below && stack_.transmits())) return scratch.stack;
    // Seen from below, into the scratch's storage (materials/stack/stack.h).
    flip_into(scratch.stack, &scratch.flipped);
    return scratch.flipped;
  }
  if (sp.from_below && stack_.transmits()) return flipped_;
  return stack_;
}

int LayeredBindings::count() const {
  int n = 0;
  for (const auto& m : by_material) n += m != nullptr;
  return n;
}

std::string ignored_by_mode(const LayeredMaterial& material, SubsurfaceMode mode) {
  std::string out;
  auto add = [&](const std::string& what) { out += (out.empty() ? "" : "; ") + what; };
  // The table mode follows texture-driven parameters, roughness included, through tables along
  // each of them (renderer/layered/layered_tables.h), and renders a rough top's glossy lobe.
  const bool smooth_only = mode == SubsurfaceMode::FirstOrder;
  if (smooth_only && material.base_stack().rough_top()) {
    std::ostringstream os;
    os << "the roughness " << material.base_stack().top_roughness
       << " of the top interface: a smooth mirror, no glossy lobe";
    add(os.str());
  }
  if (smooth_only && !material.base_stack().rough_top() && material.base_stack().energy_conserving_rough())
    add("the rough inner interfaces (bottom_roughness): smooth mirrors");
  return out;
}

}  // namespace lamina
