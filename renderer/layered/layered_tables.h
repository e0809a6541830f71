// The table mode's tables of a scene: one per layered material (and one of its flipped stack if
// it transmits), built by adding-doubling or the walk (materials/tables/layered_table.h) or loaded from
// the walk cache; and for a material with texture-driven parameters, tables along each parameter.
//
// Texture-driven parameters (renderer/layered/stack_bindings.h) in the table mode: tables at
// nodes along the parameters, interpolated, and multiplied where parameters are tabulated apart.
// An axis is a group of parameters that one map channel drives (they move together along the
// map's value t, so the group is exact along its map: head_skin's oil map sets the top's index
// and roughness), or a plane of two such groups. With T_0 the table at the base point (each
// group at its node nearest its texels' median map value, StackBindings::Nodes::central; a
// parameter the freckles drive at its template value) and T_a(x) the table with axis a at x and
// every other parameter at the base point, tabulated at kParameterNodes nodes per dimension
// where the map has its texels (StackBindings::nodes), a hit whose axes are at (x_1 .. x_A) gets,
// per incidence node, bin and channel,
//     f = T_0 prod_a T_a(x_a) / T_0,
// T_a(x) interpolated between the nodes linearly in ln T (along a line; bilinearly in ln T in a
// plane, exact at its 5 x 5 nodes). Why the logarithm: an absorber's fraction x enters every
// light path through Beer-Lambert factors exp(-sigma_a(x) s), sigma_a affine in x, so a bin is
// a positive mixture of exponentials of affine functions of the fractions, whose logarithm
// (a log-sum-exp) is convex. For a convex ln T, Jensen puts the truth at or below the
// interpolation of ln T, which (ln being concave) is at or below the linear interpolation of T:
//     T <= exp(interpolated ln T) <= interpolated T,
// so the geometric interpolation is the closer (head_skin, 64 texels: the mean green albedo
// error +1.6 % interpolating T, +0.9 % interpolating ln T; bench/table_model_error). A bin a
// node table leaves empty is interpolated linearly.
// exact when at most one axis differs from the base point and sits on its nodes, and otherwise
// the first-order (product) approximation of the cross terms between axes: with the base
// point where most texels are, the cross terms are those of the texels' departures from it. The
// plane holds the two map-driven groups whose maps' texel values are most correlated (cross
// terms have the sign of the maps' covariance in the mean: the fitted melanin and blood of a
// face rise together at the eyebrows and lips); `bench/table_model_error` measures the model
// against each texel's own table. Bins where T_0 is below 1e-12 times the node's diffuse power
// keep T_0. Sampling stays with T_0's CDF (TableSurface), so the estimator is unbiased for f
// whatever the model's error. A roughness parameter gets an axis like any other (it changes
// the light that enters the stack); the glossy lobe itself is evaluated exactly at the hit's
// roughness (renderer/surfaces/table_surface.h).
#pragma once

#include <functional>
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
  // hit): for each axis, the tables at the nodes around its value and the weights (a plane: the
  // four corners). At most kMaxFactors; returns how many were written (0 for a material with
  // no parameters). `values`: one per bound parameter.
  static constexpr int kParameterNodes = 5;
  static constexpr int kMaxFactors = 16;
  int factors(const LayeredMaterial* m, bool from_below, const Spectrum* values, TableFactor* out) const;
  // Node tables of the axes (a plane's 25 count 25; the one at the base point is T_0 itself).
  int parameter_tables() const { return parameter_tables_count_; }
  double build_seconds() const { return seconds_; }  // of the tables built (not loaded)
  int built() const { return built_; }
  int built_by_walk() const { return built_by_walk_; }  // of those built: by the walk (a fallback, or asked for)
  int loaded() const { return loaded_; }
  std::size_t bytes() const;

 private:
  // T_0 and the axes of a material with texture-driven parameters (the model above); `obtain`
  // loads or builds a stack's table.
  void build_axes(const LayeredMaterial& m, const StackBindings& b,
                  const std::function<std::unique_ptr<LayeredTable>(const LayerStack&)>& obtain);
  std::map<std::pair<const LayeredMaterial*, bool>, std::unique_ptr<LayeredTable>> tables_;
  // One axis per group of parameters one map drives, or a plane of two groups (layered_tables.h).
  struct ParameterAxis {
    std::size_t parameter[2] = {0, 0};  // per dimension, the parameter whose value places a hit
    StackBindings::Nodes nodes[2];      // its nodes; nodes[1] has none on a line
    // Per node (a line), or per node pair (i, j) at i * nodes[1].values.size() + j (a plane).
    std::vector<const LayeredTable*> tables;
  };
  std::map<std::pair<const LayeredMaterial*, bool>, std::vector<ParameterAxis>> axes_;
  std::vector<std::unique_ptr<LayeredTable>> node_tables_;  // the axes' tables but T_0

  int parameter_tables_count_ = 0;
  // The stacks tables refer to (LayeredTable::stack) that no material holds: the parameter
  // tables' stacks.
  std::vector<std::unique_ptr<LayerStack>> owned_stacks_;
  double seconds_ = 0.0;
  int built_ = 0, built_by_walk_ = 0, loaded_ = 0;
};

}  // namespace lamina
