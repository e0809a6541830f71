// renderer/walk_cache: a cached table, prediction or albedo is the computed one, bit for bit;
// keys change with everything that changes them; damaged entries are recomputed, never trusted
// or fatal.
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>

#include <gtest/gtest.h>

#include "materials/stack/stack.h"
#include "renderer/layered/layered_material.h"
#include "materials/tables/layered_table.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/surfaces/table_surface.h"
#include "renderer/layered/subsurface_auto.h"
#include "renderer/layered/walk_cache.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;

LayerStack leafish() {
  LayerStack s;
  s.name = "leafish";
  s.layers.push_back(make_layer("mesophyll", 1.45, 0.2, Spectrum(0.5, 0.1, 0.6), Spectrum(6.0), Spectrum(0.4)));
  s.below.ior = 1.33;  // a sheet on water: two different tables (top and flipped)
  return s;
}

TableSettings small_settings() {
  TableSettings ts;
  ts.nodes = 5;
  ts.bins_theta = 4;
  ts.bins_phi = 8;
  ts.walks_per_node = 300;
  return ts;
}

void expect_same_bits(const LayeredTable& a, const LayeredTable& b) {
  ASSERT_EQ(a.value.size(), b.value.size());
  ASSERT_EQ(a.cdf.size(), b.cdf.size());
  ASSERT_EQ(a.power.size(), b.power.size());
  EXPECT_EQ(std::memcmp(a.value.data(), b.value.data(), a.value.size() * sizeof(Spectrum)), 0);
  EXPECT_EQ(std::memcmp(a.cdf.data(), b.cdf.data(), a.cdf.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.power.data(), b.power.data(), a.power.size() * sizeof(double)), 0);
}

TEST(WalkCache, StoredTableLoadsBitForBit) {
  testing::TempDir dir("table-cache-roundtrip");
  const WalkCache cache((dir.path / "tables").string());
  const LayerStack s = leafish();
  const TableSettings ts = small_settings();
  EXPECT_FALSE(cache.load(s, ts).has_value());  // empty cache: a miss
  const LayeredTable built = build_layered_table(s, ts);
  cache.store(s, built);
  const std::optional<LayeredTable> loaded = cache.load(s, ts);
  ASSERT_TRUE(loaded.has_value());
  expect_same_bits(built, *loaded);
  EXPECT_EQ(loaded->stack, &s);
  EXPECT_EQ(loaded->settings.nodes, ts.nodes);
  // No temporaries left behind.
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir.path / "tables" / "tables")) {
    ++files;
    EXPECT_EQ(e.path().extension(), ".lamtable") << e.path();
  }
  EXPECT_EQ(files, 1);
}

TEST(WalkCache, KeyFollowsEverythingThatChangesATable) {
  const LayerStack s = leafish();
  const TableSettings ts = small_settings();
  const std::string key = table_cache_key(s, ts);
  EXPECT_EQ(key.size(), 32u);
  EXPECT_EQ(key, table_cache_key(s, ts));
  LayerStack renamed = s;
  renamed.name = "another name";
  EXPECT_EQ(key, table_cache_key(renamed, ts)) << "names do not change the physics";
  LayerStack one_ulp = s;
  one_ulp.layers[0].sigma_a[2] = std::nextafter(one_ulp.layers[0].sigma_a[2], 1.0);
  EXPECT_NE(key, table_cache_key(one_ulp, ts));
  LayerStack g = s;
  g.layers[0].lobes[0].g[1] = 0.41;
  EXPECT_NE(key, table_cache_key(g, ts));
  LayerStack below = s;
  below.below.ior = 1.0;
  EXPECT_NE(key, table_cache_key(below, ts));
  EXPECT_NE(key, table_cache_key(flipped(below), ts));
  for (int field = 0; field < 5; ++field) {
    TableSettings other = ts;
    if (field == 0) other.nodes += 1;
    if (field == 1) other.bins_phi += 1;
    if (field == 2) other.walks_per_node += 1;
    if (field == 3) other.seed += 1;
    if (field == 4) other.grazing_cosine *= 2.0;
    EXPECT_NE(key, table_cache_key(s, other)) << "settings field " << field;
  }
  // The executable's build id is part of the key: a rebuilt lamina rebuilds its tables.
  EXPECT_FALSE(executable_build_id().empty()) << "no GNU build id in this executable";
}

TEST(WalkCache, DamagedEntriesAreRebuiltNotTrusted) {
  testing::TempDir dir("table-cache-damaged");
  const WalkCache cache((dir.path / "tables").string());
  const LayerStack s = leafish();
  const TableSettings ts = small_settings();
  const LayeredTable built = build_layered_table(s, ts);
  cache.store(s, built);
  const std::string path = cache.path_of(s, ts);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  // Truncated, a byte appended, the magic damaged, the key of another stack.
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
  EXPECT_FALSE(cache.load(s, ts).has_value());
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes << 'x';
  EXPECT_FALSE(cache.load(s, ts).has_value());
  std::string bad_magic = bytes;
  bad_magic[0] = 'X';
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bad_magic;
  EXPECT_FALSE(cache.load(s, ts).has_value());
  LayerStack other = s;
  other.layers[0].thickness = 0.3;
  cache.store(other, build_layered_table(other, ts));
  fs::copy_file(cache.path_of(other, ts), path, fs::copy_options::overwrite_existing);
  EXPECT_FALSE(cache.load(s, ts).has_value()) << "another stack's table under this key";
  // LayeredTables rebuilds it (and rewrites the entry).
  LayeredBindings b;
  b.by_material.push_back(std::make_shared<const LayeredMaterial>(s, "leafish"));
  const LayeredTables tables(b, ts, {true}, &cache);
  EXPECT_EQ(tables.built(), 2);  // the damaged top table, and the flipped one (never stored)
  EXPECT_EQ(tables.loaded(), 0);
  ASSERT_TRUE(cache.load(s, ts).has_value());
  expect_same_bits(built, *cache.load(s, ts));
}

TEST(WalkCache, SecondSceneLoadsEveryTableAndMatchesTheBuild) {
  testing::TempDir dir("table-cache-tables");
  const WalkCache cache((dir.path / "tables").string());
  const TableSettings ts = small_settings();
  LayeredBindings b;
  b.by_material.push_back(std::make_shared<const LayeredMaterial>(leafish(), "leafish"));
  const LayeredTables first(b, ts, {true}, &cache);
  EXPECT_EQ(first.built(), 2);  // top and flipped
  EXPECT_EQ(first.loaded(), 0);
  const LayeredTables second(b, ts, {true}, &cache);
  EXPECT_EQ(second.built(), 0);
  EXPECT_EQ(second.loaded(), 2);
  EXPECT_EQ(second.build_seconds(), 0.0);
  const LayeredTables uncached(b, ts, {true});
  // A symmetric sheet (air on both sides, one layer) looks the same from below: its flipped
  // stack has the same fingerprint, so its second table is the first one, loaded.
  LayerStack symmetric = leafish();
  symmetric.below.ior = 1.0;
  LayeredBindings bs;
  bs.by_material.push_back(std::make_shared<const LayeredMaterial>(symmetric, "symmetric"));
  const LayeredTables shared(bs, ts, {true}, &cache);
  EXPECT_EQ(shared.built(), 1);
  EXPECT_EQ(shared.loaded(), 1);
  // A loaded table refers to the stack it belongs to (the zeroth order is evaluated from it).
  EXPECT_EQ(second.get(b.by_material[0].get(), false).stack, &b.by_material[0]->base_stack());
  EXPECT_NE(second.get(b.by_material[0].get(), true).stack, nullptr);
  for (bool below : {false, true}) {
    expect_same_bits(uncached.get(b.by_material[0].get(), below), second.get(b.by_material[0].get(), below));
  }
}

TEST(WalkCache, UnusableDirectoryIsAClearError) {
  testing::TempDir dir("table-cache-errors");
  std::ofstream(dir / "file") << "x";
  try {
    WalkCache cache((dir.path / "file" / "tables").string());
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("file/tables"), std::string::npos) << e.what();
  }
  if (::geteuid() != 0) {  // (root writes anywhere: as root only the case above is testable)
    fs::create_directories(dir.path / "ro");
    ::chmod((dir.path / "ro").c_str(), 0555);
    EXPECT_THROW(WalkCache((dir.path / "ro").string()), std::runtime_error);
    ::chmod((dir.path / "ro").c_str(), 0755);
  }
}

// Records: the lambert albedo and the auto prediction come back exactly, with their keys
// following the stack and the settings.
TEST(WalkCache, AlbedoAndPredictionRecordsRoundTrip) {
  testing::TempDir dir("walk-cache-records");
  const WalkCache cache((dir.path / "c").string());
  LayerStack thin;
  thin.name = "thin";
  thin.layers.push_back(make_layer("film", 1.0, 0.01, Spectrum(1.0), Spectrum(5.0), Spectrum(0.3)));
  thin.below.ior = 1.0;
  const auto computed = std::make_shared<const LayeredMaterial>(thin, "thin", 4096);
  EXPECT_FALSE(load_lambert_albedo(cache, *computed));
  const Spectrum a = computed->lambert_albedo(), se = computed->lambert_albedo_stderr();
  EXPECT_TRUE(computed->lambert_albedo_computed());
  store_lambert_albedo(cache, *computed);
  const LayeredMaterial again(thin, "thin", 4096);
  ASSERT_TRUE(load_lambert_albedo(cache, again));
  EXPECT_FALSE(again.lambert_albedo_computed());
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(again.lambert_albedo()[c], a[c]);
    EXPECT_EQ(again.lambert_albedo_stderr()[c], se[c]);
  }
  const LayeredMaterial other_walks(thin, "thin", 2048);
  EXPECT_FALSE(load_lambert_albedo(cache, other_walks)) << "another walk count is another albedo";

  LayeredBindings b;
  b.by_material.push_back(computed);
  AutoSettings as;
  as.tolerance = 0.2;
  as.walks = as.max_walks = 2000;
  const std::vector<AutoChoice> first = choose_subsurface_modes(b, as, nullptr, &cache);
  const std::vector<AutoChoice> second = choose_subsurface_modes(b, as, nullptr, &cache);
  ASSERT_EQ(first.size(), 1u);
  EXPECT_FALSE(first[0].cached);
  EXPECT_TRUE(second[0].cached);
  EXPECT_EQ(second[0].mode, first[0].mode);
  EXPECT_EQ(second[0].error_lambert, first[0].error_lambert);
  EXPECT_EQ(second[0].error_first_order, first[0].error_first_order);
  EXPECT_EQ(second[0].error_table, first[0].error_table);
  EXPECT_EQ(second[0].noise_floor, first[0].noise_floor);
  EXPECT_EQ(second[0].reason, first[0].reason);
  as.tolerance = 0.1;
  EXPECT_FALSE(choose_subsurface_modes(b, as, nullptr, &cache)[0].cached) << "another tolerance";
  // A damaged record is a miss (with a warning), then rewritten.
  for (const auto& e : fs::directory_iterator(dir.path / "c" / "auto")) std::ofstream(e.path()) << "{ not json";
  as.tolerance = 0.2;
  EXPECT_FALSE(choose_subsurface_modes(b, as, nullptr, &cache)[0].cached);
  EXPECT_TRUE(choose_subsurface_modes(b, as, nullptr, &cache)[0].cached);
}

}  // namespace
}  // namespace lamina
