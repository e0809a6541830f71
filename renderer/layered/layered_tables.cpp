#include "renderer/layered/layered_tables.h"

#include <optional>

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
    if (cache) cache->store(stack, *t);
    return t;
  };
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    const auto& m = bindings.by_material[i];
    if (!m || i >= only.size() || !only[i] || tables_.count({m.get(), false})) continue;
    // A rough top is not tabulated (its glossy lobe would need its own table): the smooth stack,
    // with the warning of render_job (ignored_by_mode). Tables point to their stack: kept here.
    const LayerStack* stack = &m->base_stack();
    if (stack->rough_top()) {
      smooth_stacks_.push_back(std::make_unique<LayerStack>(with_smooth_top(*stack)));
      stack = smooth_stacks_.back().get();
    }
    tables_[{m.get(), false}] = obtain(*stack);
    if (m->transmits()) {
      tables_[{m.get(), true}] = obtain(m->flipped_stack());
    }
  }
}

const LayeredTable& LayeredTables::get(const LayeredMaterial* m, bool from_below) const {
  auto it = tables_.find({m, from_below && m->transmits()});
  return *it->second;
}

std::size_t LayeredTables::bytes() const {
  std::size_t n = 0;
  for (const auto& [k, t] : tables_) n += t->value.size() * sizeof(Spectrum) + t->cdf.size() * sizeof(double);
  return n;
}

}  // namespace lamina
