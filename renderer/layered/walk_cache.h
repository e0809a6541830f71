// An on-disk cache of what the walk computes before rendering (`lamina render --cache DIR`;
// `lamina batch` uses OUT/cache): the table mode's tables (13-65 s for skin or a leaf), the
// `--subsurface auto` predictions (2-9 s per material) and the lambert mode's albedos. Each is a
// pure function of its stack, its settings and the code that computes it (deterministic walks),
// so one computed once is reused bit for bit by later renders and batch jobs.
//
// Key: content_hash of what it is, the stack's fingerprint (materials/stack/stack.h: every number that
// affects the light, exactly), the settings, the layout version below and the running
// executable's GNU build id (so a rebuilt lamina never reads results of a different walk).
// Files: DIR/tables/<key>.lamtable (binary, native byte order: the same machine type, a
// cluster's nodes) and DIR/<kind>/<key>.json (records: auto, albedo), written to a temporary and
// renamed, so concurrent writers (batch shards) at worst both compute and one replaces the
// other's identical file, and a reader never sees a half-written one. An entry that does not
// match (truncated, another layout, another key) is a miss: recomputed and rewritten, with a
// warning naming it.
#pragma once

#include <optional>
#include <string>

#include "materials/stack/stack.h"
#include "renderer/layered/layered_material.h"
#include "materials/tables/layered_table.h"

namespace lamina {

// The build id of the running executable (hex), or "" if it has none.
std::string executable_build_id();

// A cache key (32 hex digits) for `what` (a text naming the kind of result, its stack's
// fingerprint and its settings), with the layout version and this executable's build id.
std::string walk_cache_key(const std::string& what);
// The key of the table of `stack` with `settings`.
std::string table_cache_key(const LayerStack& stack, const TableSettings& settings);

class WalkCache {
 public:
  // Creates the directory if needed; throws std::runtime_error ("DIR: cannot create the cache
  // directory: reason" / "...is not writable") if it cannot be used.
  explicit WalkCache(std::string directory);

  // The cached table of `stack` (its `stack` pointer set to `stack`), or nullopt.
  std::optional<LayeredTable> load(const LayerStack& stack, const TableSettings& settings) const;
  // Writes `table` (built for `stack`); a failure is a warning on stderr, never an error: the
  // render has its table either way.
  void store(const LayerStack& stack, const LayeredTable& table) const;

  std::string path_of(const LayerStack& stack, const TableSettings& settings) const;

  // A small text record of kind `kind` ("auto", "albedo") under `key`: its text, or nullopt.
  std::optional<std::string> load_record(const std::string& kind, const std::string& key) const;
  // Writes it (a warning on failure, never an error).
  void store_record(const std::string& kind, const std::string& key, const std::string& text) const;
  const std::string& directory() const { return directory_; }

 private:
  std::string directory_;
};

// The lambert mode's albedo of `material` (its base stack and walk count): loaded from the cache
// into the material (true if found), and stored if the material computed it.
bool load_lambert_albedo(const WalkCache& cache, const LayeredMaterial& material);
void store_lambert_albedo(const WalkCache& cache, const LayeredMaterial& material);

}  // namespace lamina
