#include "renderer/layered/layered_material.h"

#include <sstream>

#include "materials/albedo.h"
#include "renderer/layered/stack_bindings.h"

namespace lamina {

LayeredMaterial::LayeredMaterial(LayerStack stack, std::string source, int albedo_walks)
    : stack_(std::move(stack)), source_(std::move(source)), albedo_walks_(albedo_walks) {
  if (stack_.transmits()) flipped_ = flipped(stack_);
}

const Spectrum& LayeredMaterial::lambert_albedo() const {
  // Computed once per material, on first use.
  std::call_once(albedo_once_, [this] {
    lambert_albedo_ = diffuse_bihemispherical_albedo(stack_, albedo_walks_, kAlbedoSeed, &lambert_albedo_stderr_);
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

const LayerStack& LayeredMaterial::stack_at(const ShadingPoint& sp, StackScratch& scratch) const {
  if (bindings_) {
    // Texture-driven parameters: the stack at this uv, built in the caller's scratch (no
    // allocation once its vectors have grown; stack_bindings.h).
    bindings_->evaluate(sp.uv, &scratch.stack);
    if (!(sp.from_below && stack_.transmits())) return scratch.stack;
    // Seen from below, into the scratch's storage (materials/stack.h).
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
  const bool maps_dropped = mode == SubsurfaceMode::Table || mode == SubsurfaceMode::Lambert;
  if (maps_dropped && material.bindings() && !material.bindings()->empty()) {
    std::string names;
    for (const StackParameter& p : material.bindings()->parameters()) names += (names.empty() ? "" : ", ") + p.path;
    add("the texture-driven parameters (" + names + "): the base stack everywhere");
  }
  const bool smooth_only = mode == SubsurfaceMode::Table || mode == SubsurfaceMode::FirstOrder;
  if (smooth_only && material.base_stack().rough_top()) {
    std::ostringstream os;
    os << "the roughness " << material.base_stack().top_roughness
       << " of the top interface: a smooth mirror, no glossy lobe";
    add(os.str());
  }
  return out;
}

}  // namespace lamina
