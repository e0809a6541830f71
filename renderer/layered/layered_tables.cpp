#include "renderer/layered/layered_tables.h"

#include <algorithm>
#include <array>
#include <optional>

#include "materials/stack/stack_parameters.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/walk_cache.h"

namespace lamina {

LayeredTables::LayeredTables(const LayeredBindings& bindings, const TableSettings& settings)
    : LayeredTables(bindings, settings, std::vector<bool>(bindings.by_material.size(), true)) {}

LayeredTables::LayeredTables(const LayeredBindings& bindings, const TableSettings& settings, const std::vector<bool>& only,
                             const WalkCache* cache) {
  // The table of `stack`: from the cache if it has it, else built (and stored).
  auto obtain = [&](const LayerStack& stack) {
    if (cache) {
      if (std::optional<LayeredTable> t = cache->load(stack, settings)) {
        ++loaded_;
        return std::make_unique<LayeredTable>(std::move(*t));
      }
    }
    auto t = std::make_unique<LayeredTable>(build_layered_table(stack, settings));
    seconds_ += t->build_seconds;
    ++built_;
    if (t->walk_fallback || settings.method == TableSettings::Method::MonteCarlo) ++built_by_walk_;
    if (cache) cache->store(stack, *t);
    return t;
  };
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    const auto& m = bindings.by_material[i];
    if (!m || i >= only.size() || !only[i] || tables_.count({m.get(), false})) continue;
    // A rough top is tabulated as it is: the table holds all but the top's first-order glossy
    // lobe (and the delta lobes), which the surface adds exactly (renderer/surfaces/
    // table_surface.h); energy-conserving rough interfaces, at the top or inside, are in
    // adding-doubling (materials/adding_doubling/adding_doubling.h).
    const LayerStack* stack = &m->base_stack();
    const StackBindings* b = m->bindings();
    if (!b || b->empty()) {
      tables_[{m.get(), false}] = obtain(*stack);
      if (m->transmits()) tables_[{m.get(), true}] = obtain(m->flipped_stack());
      continue;
    }
    // Texture-driven parameters (the model in layered_tables.h): T_0 from the template's values,
    // and per parameter that changes a table, its tables at kParameterNodes values.
    const std::vector<StackParameter>& ps = b->parameters();
    const StackTemplate& t = b->stack_template();
    std::vector<Spectrum> values(ps.size());
    for (std::size_t k = 0; k < ps.size(); ++k) values[k] = ps[k].template_value(t);
    // The stack (and its flipped copy) for the given values, kept alive here.
    const int sides = m->transmits() ? 2 : 1;
    auto stacks_for = [&](const std::vector<Spectrum>& v) {
      std::array<const LayerStack*, 2> pair{nullptr, nullptr};
      auto up = std::make_unique<LayerStack>();
      apply_parameters(t, ps, v.data(), up.get());
      pair[0] = up.get();
      if (sides == 2) {
        owned_stacks_.push_back(std::make_unique<LayerStack>(flipped(*up)));
        pair[1] = owned_stacks_.back().get();
      }
      owned_stacks_.push_back(std::move(up));
      return pair;
    };
    // A parameter its map holds constant has one node: T_0 takes that value (no axis below).
    for (std::size_t k = 0; k < ps.size(); ++k) {
      const StackBindings::Nodes n = b->nodes(k, kParameterNodes);
      if (n.values.size() == 1) values[k] = n.values[0];
    }
    const auto base = stacks_for(values);
    for (int side = 0; side < sides; ++side) tables_[{m.get(), side == 1}] = obtain(*base[side]);
    for (std::size_t k = 0; k < ps.size(); ++k) {
      ParameterAxis axis[2];
      axis[0].nodes = b->nodes(k, kParameterNodes);
      if (axis[0].nodes.values.size() < 2) continue;  // a constant parameter: nothing to interpolate
      std::vector<Spectrum> v = values;
      for (const Spectrum& node_value : axis[0].nodes.values) {
        v[k] = node_value;
        const auto node = stacks_for(v);
        for (int side = 0; side < sides; ++side) {
          axis[side].tables.push_back(obtain(*node[side]));
          ++parameter_tables_count_;
        }
      }
      // Both sides' nodes before either axis is moved away.
      for (int side = 0; side < sides; ++side) {
        axis[side].parameter = k;
        axis[side].nodes = axis[0].nodes;
      }
      for (int side = 0; side < sides; ++side) axes_[{m.get(), side == 1}].push_back(std::move(axis[side]));
    }
  }
}

int LayeredTables::factors(const LayeredMaterial* m, bool from_below, const Spectrum* values, TableFactor* out) const {
  auto it = axes_.find({m, from_below && m->transmits()});
  if (it == axes_.end()) return 0;
  int n = 0;
  for (const ParameterAxis& a : it->second) {
    if (n == kMaxFactors) break;
    std::size_t j = 0;
    double t = 0.0;
    a.nodes.bracket(values[a.parameter][a.nodes.channel], &j, &t);
    out[n++] = TableFactor{a.tables[j].get(), a.tables[j + 1].get(), t};
  }
  return n;
}

const LayeredTable& LayeredTables::get(const LayeredMaterial* m, bool from_below) const {
  auto it = tables_.find({m, from_below && m->transmits()});
  return *it->second;
}

std::size_t LayeredTables::bytes() const {
  std::size_t n = 0;
  auto add = [&](const LayeredTable& t) { n += t.value.size() * sizeof(Spectrum) + t.cdf.size() * sizeof(double); };
  for (const auto& [k, t] : tables_) add(*t);
  for (const auto& [k, axes] : axes_)
    for (const ParameterAxis& a : axes)
      for (const auto& t : a.tables) add(*t);
  return n;
}

}  // namespace lamina
