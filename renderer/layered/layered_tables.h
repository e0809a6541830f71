// The table mode's tables of a scene: one per layered material (and one of its flipped stack if
// it transmits), built by the walk (materials/layered_table.h) or loaded from the walk cache.
#pragma once

#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "materials/layered_table.h"
#include "renderer/layered/layered_material.h"

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
  double build_seconds() const { return seconds_; }  // of the tables built (not loaded)
  int built() const { return built_; }
  int loaded() const { return loaded_; }
  std::size_t bytes() const;

 private:
  std::map<std::pair<const LayeredMaterial*, bool>, std::unique_ptr<LayeredTable>> tables_;
  // The smooth-top copies of rough stacks that tables refer to (LayeredTable::stack).
  std::vector<std::unique_ptr<LayerStack>> smooth_stacks_;
  double seconds_ = 0.0;
  int built_ = 0, loaded_ = 0;
};

}  // namespace lamina
