// Layered (Hanrahan-Krueger) materials of a scene: the stack a glTF material is rendered with
// (bound by renderer/layered/material_binding.h) and what the shading modes need of it.
//
// One place gives the stack at a hit: LayeredMaterial::stack_at(). It returns the material's
// base stack today; texture-driven parameters (blood, melanin, oil, freckles) are computed there
// into the caller's per-thread scratch, so the integrator and every --subsurface mode see them.
#pragma once

#include <cstdint>
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/subsurface_mode.h"

namespace lamina {

struct SceneDesc;

// What stack_at() may look at: the hit as the integrator sees it.
struct ShadingPoint {
  glm::dvec3 p{0.0};      // world position
  glm::dvec2 uv{0.0};     // texture coordinates (TEXCOORD_0)
  int mesh = -1;
  int triangle = -1;
  // The viewer is on the back side (against the triangle's wound normal) of a stack that
  // transmits: the stack is seen from below and stack_at returns it flipped (a leaf lit from
  // behind). For a stack that does not transmit (skin over flesh, a closed mesh) the side the
  // ray comes from is always the top, and this is false.
  bool from_below = false;
};

// Per-thread scratch in which stack_at() may build a stack for this hit (texture-driven
// parameters), so that no allocation happens per hit once its vectors have grown.
struct StackScratch {
  LayerStack stack;
  LayerStack flipped;
};

class LayeredMaterial {
 public:
  // `stack` must be valid (validate_stack() empty). `source` is the stack file, for messages.
  // `albedo_walks`: the walks of lambert_albedo() (tests of costly stacks use fewer).
  LayeredMaterial(LayerStack stack, std::string source, int albedo_walks = kDefaultAlbedoWalks);
  // 2^15 walks: a standard error of about 0.003 on an albedo of 0.5 (printed by lamina render).
  static constexpr int kDefaultAlbedoWalks = 1 << 15;
  // With texture-driven parameters (renderer/layered/stack_bindings.h): stack_at() evaluates them at
  // the hit's uv. The Lambert albedo stays that of the base stack.
  LayeredMaterial(LayerStack stack, std::string source, std::shared_ptr<const StackBindings> bindings);

  // The stack at this hit, seen from the viewer's side (flipped when sp.from_below). The result
  // refers either to this material's own stacks or to `scratch`; valid until the next call with
  // the same scratch.
  const LayerStack& stack_at(const ShadingPoint& sp, StackScratch& scratch) const;

  const LayerStack& base_stack() const { return stack_; }
  // The base stack seen from below (flipped()); only for a stack that transmits.
  const LayerStack& flipped_stack() const { return flipped_; }
  const std::string& source() const { return source_; }
  const StackBindings* bindings() const { return bindings_.get(); }
  bool transmits() const { return stack_.transmits(); }

  // The stack's diffuse bihemispherical reflectance (white-sky albedo of R_diffuse: the light
  // that scattered at least once and left through the top, averaged over cosine-weighted
  // incidence), estimated by the random walk when the material is made. The `lambert` mode's
  // albedo. lambert_albedo_stderr is its standard error.
  // Computed on first use (thread-safe), so that modes that do not need it do not pay for it.
  const Spectrum& lambert_albedo() const;
  const Spectrum& lambert_albedo_stderr() const;
  int albedo_walks() const { return albedo_walks_; }
  static constexpr std::uint64_t kAlbedoSeed = 0x1a3bULL;
  // A value computed earlier for this stack and walk count (renderer/layered/walk_cache.h), set before
  // first use; false (and ignored) if the albedo is already known.
  bool preset_lambert_albedo(const Spectrum& albedo, const Spectrum& standard_error) const;
  // True once the albedo has been computed by this material's own walks (not preset).
  bool lambert_albedo_computed() const { return albedo_state_.load() == 1; }

  // The lambert mode's albedo at a hit, honouring texture-driven parameters: without bindings,
  // lambert_albedo(). With them, a separable model around the template stack t (the file's
  // values): A(p) = A(t) prod_k A(t with p_k) / A(t), each factor interpolated linearly between
  // kLambertNodes values of p_k where its map's texels are (StackBindings::nodes), computed by the walk
  // on first use (kLambertNodeWalks walks each, one seed: the ratios share their random numbers).
  // Exact for one parameter at the nodes; the cross terms of several are left out (docs/modes.md measures
  // the error on head_skin and leaves_back).
  Spectrum lambert_albedo_at(glm::dvec2 uv) const;
  static constexpr int kLambertNodes = 5;
  static constexpr int kLambertNodeWalks = 1 << 13;

 private:
  LayerStack stack_;
  LayerStack flipped_;  // flipped(stack_) if it transmits, else unused
  std::shared_ptr<const StackBindings> bindings_;  // null: the base stack everywhere
  std::string source_;
  int albedo_walks_ = kDefaultAlbedoWalks;
  mutable std::once_flag albedo_once_;
  mutable std::atomic<int> albedo_state_{0};  // 0 unknown, 1 computed, 2 preset
  mutable Spectrum lambert_albedo_, lambert_albedo_stderr_;
  // lambert_albedo_at's model: per parameter, its node values (channel of the widest range) and
  // the albedo ratios A(t with node) / A(t).
  struct AlbedoFactor {
    StackBindings::Nodes nodes;
    std::vector<Spectrum> ratio;  // per node
  };
  mutable std::once_flag factors_once_;
  mutable std::vector<AlbedoFactor> factors_;
  // The parameters the maps hold constant, as one factor: the albedo at their values over the
  // template's (1 when none).
  mutable Spectrum constant_factor_{1.0};
};

// What a --subsurface mode leaves out of this material, for the warning and the EXR header
// (`lamina:ignored:MATERIAL`): "" if it renders everything. The first-order mode evaluates the
// stack per hit (texture-driven parameters honoured) through a smooth top (its analytic
// solutions never read the roughness); the table mode
// tabulates the base stack with a smooth top; the lambert mode follows the parameters through
// lambert_albedo_at (approximately, and never a glossy lobe: no warning).
// Only random-walk renders a rough top's glossy lobe and everything the maps drive.
std::string ignored_by_mode(const LayeredMaterial& material, SubsurfaceMode mode);

// The layered materials of a scene, one slot per glTF material (null: not layered).
struct LayeredBindings {
  std::vector<std::shared_ptr<const LayeredMaterial>> by_material;
  const LayeredMaterial* get(int material) const {
    return material >= 0 && material < static_cast<int>(by_material.size()) ? by_material[material].get() : nullptr;
  }
  int count() const;
};

}  // namespace lamina
