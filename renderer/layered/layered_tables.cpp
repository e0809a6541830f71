#include "renderer/layered/layered_tables.h"

#include <algorithm>
#include <array>
#include <cmath>
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
    build_axes(*m, *b, obtain);
  }
}

namespace {

// Pearson's correlation of two equally long sequences (0 if either is constant or they differ in
// length).
double correlation(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size() || x.empty()) return 0.0;
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i];
  mx /= static_cast<double>(x.size()), my /= static_cast<double>(y.size());
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  return sxx > 0.0 && syy > 0.0 ? sxy / std::sqrt(sxx * syy) : 0.0;
}

// Parameters that move together: one map channel drives them all (or one parameter alone).
struct ParameterGroup {
  std::vector<std::size_t> members;          // the first places a hit (its nodes)
  StackBindings::Nodes nodes;                // the first member's
  std::vector<std::vector<Spectrum>> value;  // [node][member]
  std::size_t base = 0;                      // the base point's node (map-driven groups)
  bool at_node = false;                      // the base point is node `base`
};

std::vector<ParameterGroup> parameter_groups(const StackBindings& b, int count, std::vector<Spectrum>* base_values) {
  std::vector<ParameterGroup> groups;
  for (std::size_t k = 0; k < b.parameters().size(); ++k) {
    StackBindings::Nodes n = b.nodes(k, count);
    if (n.values.size() < 2) {  // constant over the surface: the base point takes its value
      (*base_values)[k] = n.values[0];
      continue;
    }
    auto same = std::find_if(groups.begin(), groups.end(), [&](const ParameterGroup& g) {
      return !n.source.empty() && g.nodes.source == n.source && g.nodes.t.size() == n.t.size();
    });
    if (same == groups.end()) {
      ParameterGroup g;
      g.members = {k};
      for (const Spectrum& v : n.values) g.value.push_back({v});
      if (!n.source.empty()) g.base = n.central, g.at_node = true;
      g.nodes = std::move(n);
      groups.push_back(std::move(g));
      continue;
    }
    // The same map values t (map_nodes of the same texels), maybe in the opposite order (a range
    // that runs the other way): node j of the group is the member's node at the same t.
    same->members.push_back(k);
    for (std::size_t j = 0; j < same->nodes.t.size(); ++j) {
      std::size_t i = 0;
      for (std::size_t q = 1; q < n.t.size(); ++q)
        if (std::abs(n.t[q] - same->nodes.t[j]) < std::abs(n.t[i] - same->nodes.t[j])) i = q;
      same->value[j].push_back(n.values[i]);
    }
  }
  for (const ParameterGroup& g : groups)
    if (g.at_node)
      for (std::size_t q = 0; q < g.members.size(); ++q) (*base_values)[g.members[q]] = g.value[g.base][q];
  return groups;
}

}  // namespace

void LayeredTables::build_axes(const LayeredMaterial& m, const StackBindings& b,
                               const std::function<std::unique_ptr<LayeredTable>(const LayerStack&)>& obtain) {
  const std::vector<StackParameter>& ps = b.parameters();
  const StackTemplate& tmpl = b.stack_template();
  std::vector<Spectrum> values(ps.size());
  for (std::size_t k = 0; k < ps.size(); ++k) values[k] = ps[k].template_value(tmpl);
  const std::vector<ParameterGroup> groups = parameter_groups(b, kParameterNodes, &values);
  // The plane: the two map-driven groups whose maps are most correlated.
  int plane[2] = {-1, -1};
  double best = -1.0;
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (std::size_t h = g + 1; h < groups.size(); ++h) {
      if (!groups[g].at_node || !groups[h].at_node) continue;
      const double r = std::abs(correlation(b.texel_values(groups[g].members[0], groups[g].nodes.channel),
                                            b.texel_values(groups[h].members[0], groups[h].nodes.channel)));
      if (r > best) best = r, plane[0] = static_cast<int>(g), plane[1] = static_cast<int>(h);
    }
  const int sides = m.transmits() ? 2 : 1;
  // The tables (one per side) with the groups `at` at their nodes and the rest at the base point;
  // T_0 itself where every one of them sits at its base node.
  auto tables_at = [&](const std::vector<std::pair<const ParameterGroup*, std::size_t>>& at) {
    std::array<const LayeredTable*, 2> out{nullptr, nullptr};
    if (std::all_of(at.begin(), at.end(), [](const auto& p) { return p.first->at_node && p.second == p.first->base; })) {
      for (int side = 0; side < sides; ++side) out[side] = tables_.at({&m, side == 1}).get();
      return out;
    }
    std::vector<Spectrum> v = values;
    for (const auto& [g, j] : at)
      for (std::size_t q = 0; q < g->members.size(); ++q) v[g->members[q]] = g->value[j][q];
    auto up = std::make_unique<LayerStack>();
    apply_parameters(tmpl, ps, v.data(), up.get());
    node_tables_.push_back(obtain(*up));
    out[0] = node_tables_.back().get();
    if (sides == 2) {
      owned_stacks_.push_back(std::make_unique<LayerStack>(flipped(*up)));
      node_tables_.push_back(obtain(*owned_stacks_.back()));
      out[1] = node_tables_.back().get();
    }
    owned_stacks_.push_back(std::move(up));
    return out;
  };
  // T_0 at the base point.
  {
    auto up = std::make_unique<LayerStack>();
    apply_parameters(tmpl, ps, values.data(), up.get());
    tables_[{&m, false}] = obtain(*up);
    if (sides == 2) {
      owned_stacks_.push_back(std::make_unique<LayerStack>(flipped(*up)));
      tables_[{&m, true}] = obtain(*owned_stacks_.back());
    }
    owned_stacks_.push_back(std::move(up));
  }
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (static_cast<int>(g) == plane[1]) continue;  // in the plane with plane[0]
    const bool in_plane = static_cast<int>(g) == plane[0];
    const ParameterGroup* second = in_plane ? &groups[plane[1]] : nullptr;
    ParameterAxis axis[2];
    for (int side = 0; side < sides; ++side) {
      axis[side].parameter[0] = groups[g].members[0];
      axis[side].nodes[0] = groups[g].nodes;
      if (second) {
        axis[side].parameter[1] = second->members[0];
        axis[side].nodes[1] = second->nodes;
      }
    }
    for (std::size_t i = 0; i < groups[g].nodes.values.size(); ++i) {
      const std::size_t n2 = second ? second->nodes.values.size() : 1;
      for (std::size_t j = 0; j < n2; ++j) {
        std::vector<std::pair<const ParameterGroup*, std::size_t>> at = {{&groups[g], i}};
        if (second) at.push_back({second, j});
        const auto t = tables_at(at);
        for (int side = 0; side < sides; ++side) {
          axis[side].tables.push_back(t[side]);
          ++parameter_tables_count_;
        }
      }
    }
    for (int side = 0; side < sides; ++side) axes_[{&m, side == 1}].push_back(std::move(axis[side]));
  }
}

int LayeredTables::factors(const LayeredMaterial* m, bool from_below, const Spectrum* values, TableFactor* out) const {
  auto it = axes_.find({m, from_below && m->transmits()});
  if (it == axes_.end()) return 0;
  int n = 0;
  for (const ParameterAxis& a : it->second) {
    if (n == kMaxFactors) break;
    std::size_t i = 0, j = 0;
    double t = 0.0, t2 = 0.0;
    a.nodes[0].bracket(values[a.parameter[0]][a.nodes[0].channel], &i, &t);
    TableFactor& f = out[n++];
    if (a.nodes[1].values.empty()) {
      f = TableFactor{a.tables[i], a.tables[i + 1], t};
      continue;
    }
    a.nodes[1].bracket(values[a.parameter[1]][a.nodes[1].channel], &j, &t2);
    const std::size_t n2 = a.nodes[1].values.size();
    f = TableFactor{a.tables[i * n2 + j], a.tables[(i + 1) * n2 + j], t, a.tables[i * n2 + j + 1],
                    a.tables[(i + 1) * n2 + j + 1], t2};
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
  for (const auto& t : node_tables_) add(*t);
  return n;
}

}  // namespace lamina
