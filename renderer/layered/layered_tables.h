// The table mode's tables of a scene: one per layered material (and one of its flipped stack if
// it transmits), built by adding-doubling or the walk (materials/tables/layered_table.h) or loaded from
// the walk cache; and for a material with texture-driven parameters, tables along each parameter.
//
// Texture-driven parameters (renderer/layered/stack_bindings.h) in the table mode: a separable
// model, as the lambert mode's albedo (LayeredMaterial::lambert_albedo_at). With T_0 the table of
// the template (every parameter at its template value) and T_k(x) the table with parameter k at
// x and the others at their template values, tabulated at kParameterNodes values of x where the
// parameter's map has its texels (StackBindings::nodes) and interpolated linearly between them, a hit whose parameters are
// (x_1 .. x_K) gets, per incidence node, bin and channel,
//     f = T_0 prod_k T_k(x_k) / T_0,
// exact when at most one parameter differs from its template value and that one sits on a node,
// and otherwise the first-order (product) approximation of the cross terms. Bins where T_0 is
// below 1e-12 times the node's diffuse power keep T_0. Sampling stays with T_0's CDF (TableSurface), so
// the estimator is unbiased for f whatever the model's error. A roughness parameter gets an axis
// like any other (it changes the light that enters the stack); the glossy lobe itself is
// evaluated exactly at the hit's roughness (renderer/surfaces/table_surface.h).
#pragma once

#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "materials/tables/layered_table.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/surfaces/table_surface.h"

namespace lamina {

class WalkCache;

// Tables of every layered material of a scene (and of its flipped stack if it transmits).
class LayeredTables {
 public:
  LayeredTables(const LayeredBindings& bindings, const TableSettings& settings);
  // Only the materials whose slot in `only` is true (`--subsurface auto`: those that chose table).
  // With a cache (renderer/layered/walk_cache.h), tables found there are loaded instead of built, and
  // the ones built are stored.
  LayeredTables(const LayeredBindings& bindings, const TableSettings& settings, const std::vector<bool>& only,
                const WalkCache* cache = nullptr);
  const LayeredTable& get(const LayeredMaterial* m, bool from_below) const;
  // The factors of the hit's texture-driven parameters (values from StackBindings::values at the
  // hit): for each parameter axis, the tables at the two nodes around its value and the weight
  // of the upper one. At most kMaxFactors; returns how many were written (0 for a material with
  // no parameters). `values`: one per bound parameter.
  static constexpr int kParameterNodes = 5;
  static constexpr int kMaxFactors = 16;
  int factors(const LayeredMaterial* m, bool from_below, const Spectrum* values, TableFactor* out) const;
  int parameter_tables() const { return parameter_tables_count_; }
  double build_seconds() const { return seconds_; }  // of the tables built (not loaded)
  int built() const { return built_; }
  int built_by_walk() const { return built_by_walk_; }  // of those built: by the walk (a fallback, or asked for)
  int loaded() const { return loaded_; }
  std::size_t bytes() const;

 private:
  std::map<std::pair<const LayeredMaterial*, bool>, std::unique_ptr<LayeredTable>> tables_;
  // One axis per texture-driven parameter that changes the table.
  struct ParameterAxis {
    std::size_t parameter = 0;  // index into the material's StackBindings::parameters()
    StackBindings::Nodes nodes;
    std::vector<std::unique_ptr<LayeredTable>> tables;  // per node
  };
  std::map<std::pair<const LayeredMaterial*, bool>, std::vector<ParameterAxis>> axes_;

  int parameter_tables_count_ = 0;
  // The stacks tables refer to (LayeredTable::stack) that no material holds: the parameter
  // tables' stacks.
  std::vector<std::unique_ptr<LayerStack>> owned_stacks_;
  double seconds_ = 0.0;
  int built_ = 0, built_by_walk_ = 0, loaded_ = 0;
};

}  // namespace lamina
