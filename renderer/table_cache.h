// An on-disk cache of the table mode's tables (`lamina render --table-cache DIR`; `lamina batch`
// uses OUT/cache/tables). A table is a pure function of its stack, its TableSettings and the
// code that builds it (deterministic walks: renderer/layered_table.h), so a table built once can
// be reused bit for bit by later renders and batch jobs instead of being rebuilt (13-65 s for
// skin or a leaf).
//
// Key: content_hash of the stack's fingerprint (materials/stack.h: every number that affects the
// light, exactly), the settings, the layout version below and the running executable's GNU
// build id (so a rebuilt lamina never reads tables of a different walk). File:
// DIR/<key>.lamtable, binary, native byte order (same machine type: a cluster's nodes), written
// to a temporary and renamed, so concurrent writers (batch shards) at worst both build and one
// replaces the other's identical file, and a reader never sees a half-written table. A file that
// does not match (truncated, another layout, another key) is a miss: rebuilt and rewritten, with a
// warning naming it.
#pragma once

#include <optional>
#include <string>

#include "materials/stack.h"
#include "renderer/layered_table.h"

namespace lamina {

// The build id of the running executable (hex), or "" if it has none.
std::string executable_build_id();

// The cache key of the table of `stack` with `settings` (32 hex digits).
std::string table_cache_key(const LayerStack& stack, const TableSettings& settings);

class TableCache {
 public:
  // Creates the directory if needed; throws std::runtime_error ("DIR: cannot create the table
  // cache directory: reason" / "...is not writable") if it cannot be used.
  explicit TableCache(std::string directory);

  // The cached table of `stack` (its `stack` pointer set to `stack`), or nullopt.
  std::optional<LayeredTable> load(const LayerStack& stack, const TableSettings& settings) const;
  // Writes `table` (built for `stack`); a failure is a warning on stderr, never an error: the
  // render has its table either way.
  void store(const LayerStack& stack, const LayeredTable& table) const;

  std::string path_of(const LayerStack& stack, const TableSettings& settings) const;
  const std::string& directory() const { return directory_; }

 private:
  std::string directory_;
};

}  // namespace lamina
