// Batch manifests: parsing and its errors, job expansion (counts, order, stable ids and
// hashes), stack overrides and renormalisation, comparisons, shards, contact sheet layout, and
// the example manifests in scenes/batch/.
#include <algorithm>
#include <filesystem>
#include <limits>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "renderer/batch/batch_manifest.h"
#include "renderer/image/contact_sheet.h"
#include "renderer/scene/gltf_document.h"
#include "renderer/scene/scene_gltf.h"
#include "tests/renderer/batch_fixture.h"

namespace lamina {
namespace {

using nlohmann::json;
using testing::TempDir;

struct Fixture {
  TempDir dir{"batch-manifest"};
  Fixture() {
    testing::write_batch_quad(dir / "quad.gltf");
    testing::write_batch_quad(dir / "quad_bin.gltf", "quad.bin");
    testing::write_json(dir / "stack.json", testing::small_stack());
  }
  // scenes 2 x variants 3 x lighting 2 x modes 2 x spp 2 = 48 jobs.
  json manifest() const {
    return json::parse(R"({
      "lamina_batch": 1,
      "settings": { "width": 16, "height": 12, "seed": 3, "max_depth": 5 },
      "scenes": [ { "name": "a", "file": "quad.gltf", "materials": { "skin": "stack.json" } },
                  { "name": "b", "file": "quad_bin.gltf", "materials": { "skin": "stack.json" } } ],
      "variants": [ { "name": "base" },
                    { "name": "thin", "overrides": [ { "material": "skin", "set": { "layers[1].thickness": 0.2 } } ] },
                    { "name": "blood5", "overrides": [ { "material": "skin", "renormalise": true,
                        "set": { "layers[1].components[0].fraction": 0.05 } } ] } ],
      "lighting": [ { "name": "grey", "env": 1 }, { "name": "sky", "env": [0.2, 0.3, 1.0], "camera": "front" } ],
      "modes": [ "random-walk", "lambert" ],
      "spp": [ 4, 16 ],
      "comparisons": [ { "name": "lambert", "reference": { "mode": "random-walk" }, "test": { "mode": "lambert" } } ]
    })");
  }
  Manifest parse(const json& j) const { return parse_manifest(j, "m.json", dir.path.string()); }
};

// The error names the manifest, the JSON path and the problem.
void expect_error(const Fixture& f, const json& j, const std::string& path, const std::string& what) {
  try {
    const Manifest m = f.parse(j);
    const std::vector<BatchJob> jobs = expand_jobs(m);
    resolve_comparisons(m, jobs);
    ADD_FAILURE() << "no error for " << path;
  } catch (const ManifestError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("m.json"), std::string::npos) << msg;
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(BatchManifest, ParsesAndAppliesDefaults) {
  Fixture f;
  const Manifest m = f.parse(f.manifest());
  EXPECT_EQ(m.scenes.size(), 2u);
  EXPECT_EQ(m.variants.size(), 3u);
  EXPECT_EQ(m.lighting[0].env, "1");
  EXPECT_EQ(m.lighting[1].env, "0.2,0.3,1.0");
  EXPECT_EQ(m.lighting[1].camera, "front");
  EXPECT_EQ(m.settings.width, 16);
  EXPECT_EQ(m.settings.seed, 3u);

  json minimal = {{"lamina_batch", 1}, {"scenes", {{{"name", "a"}, {"file", "quad.gltf"}}}}, {"spp", 8}};
  const Manifest d = f.parse(minimal);
  ASSERT_EQ(d.variants.size(), 1u);
  EXPECT_EQ(d.variants[0].name, "base");
  ASSERT_EQ(d.lighting.size(), 1u);
  EXPECT_EQ(d.lighting[0].name, "default");
  ASSERT_EQ(d.modes.size(), 1u);
  EXPECT_EQ(d.modes[0].name, "random-walk");
  EXPECT_EQ(d.modes[0].subsurface.name(), "random-walk");
  EXPECT_EQ(d.modes[0].subsurface.tolerance, 0.0);
  EXPECT_EQ(d.spp, std::vector<int>{8});
  EXPECT_EQ(expand_jobs(d).size(), 1u);
}

TEST(BatchManifest, ErrorsNameFileAndPath) {
  Fixture f;
  json j;
  j = f.manifest(); j["colour"] = 1;                          expect_error(f, j, "colour", "unknown key");
  j = f.manifest(); j.erase("lamina_batch");                  expect_error(f, j, "m.json", "lamina_batch");
  j = f.manifest(); j["lamina_batch"] = 2;                    expect_error(f, j, "lamina_batch", "version");
  j = f.manifest(); j["scenes"][1]["file"] = "nope.gltf";     expect_error(f, j, "scenes[1].file", "does not exist");
  j = f.manifest(); j["scenes"][1]["name"] = "a";             expect_error(f, j, "scenes[1].name", "duplicate");
  j = f.manifest(); j["scenes"][0]["name"] = "a__b";          expect_error(f, j, "scenes[0].name", "__");
  j = f.manifest(); j["scenes"][0]["name"] = "../x";          expect_error(f, j, "scenes[0].name", "letters");
  j = f.manifest(); j["scenes"][0]["materials"] = {{"leaf", "stack.json"}};
  expect_error(f, j, "scenes[0].materials.leaf", "not a material");
  j = f.manifest(); j["variants"][1]["overrides"][0]["material"] = "leaf";
  expect_error(f, j, "variants[1].overrides[0].material", "not a material");
  j = f.manifest(); j["variants"][1]["overrides"][0]["set"] = {{"layers[7].thickness", 1.0}};
  expect_error(f, j, "variants[1].overrides[0]", "layers[7]");
  j = f.manifest(); j["variants"][1]["overrides"][0]["set"] = {{"layers[1].thicknes", 1.0}};
  expect_error(f, j, "variants[1].overrides[0]", "thicknes");
  j = f.manifest(); j["variants"][1]["overrides"][0]["set"] = {{"layers[1..x", 1.0}};
  expect_error(f, j, "variants[1].overrides[0].set", "bad stack path");
  j = f.manifest(); j["variants"][1]["overrides"][0]["set"] = {{"layers[1].thickness", "thick"}};
  expect_error(f, j, "layers[1].thickness", "expected a finite number");
  j = f.manifest(); j["variants"][2]["overrides"][0]["set"] = {{"layers[1].components[0].fraction", 1.5}};
  expect_error(f, j, "variants[2].overrides[0]", "more than 1");
  j = f.manifest(); j["lighting"][1]["camera"] = "back";      expect_error(f, j, "lighting[1].camera", "no camera 'back'");
  j = f.manifest(); j["lighting"][0]["env"] = -1;             expect_error(f, j, "lighting[0].env", ">= 0");
  j = f.manifest(); j["lighting"][0]["env"] = "sky.exr";      expect_error(f, j, "lighting[0].env", "does not exist");
  j = f.manifest(); j["modes"] = {"random-walk", "photon"};   expect_error(f, j, "modes[1]", "unknown mode");
  j = f.manifest(); j["spp"] = {4, 0};                        expect_error(f, j, "spp[1]", "out of range");
  j = f.manifest(); j.erase("spp");                           expect_error(f, j, "m.json", "spp");
  j = f.manifest(); j["settings"]["width"] = 0;               expect_error(f, j, "settings.width", "out of range");
  j = f.manifest(); j["comparisons"][0]["test"]["mode"] = "first-order";
  expect_error(f, j, "comparisons[0].test.mode", "not in the batch");
  j = f.manifest(); j["comparisons"][0]["test"] = {{"spp", 32}};
  expect_error(f, j, "comparisons[0].test.spp", "not in the batch");
  j = f.manifest(); j["comparisons"][0]["reference"] = json::object();
  expect_error(f, j, "comparisons[0]", "matches no pair");
}

// "modes" entries as objects: {"name", "subsurface", "tolerance"}; the name is the job axis.
TEST(BatchManifest, AutoModeObjects) {
  Fixture f;
  json j = f.manifest();
  j["modes"] = json::parse(R"([ "random-walk",
                                { "subsurface": "auto", "tolerance": 0.05 },
                                { "name": "coarse", "subsurface": "auto", "tolerance": 1 },
                                { "name": "walk2", "subsurface": "first-order" },
                                { "subsurface": "lambert" } ])");
  j["comparisons"] = {{{"name", "auto"}, {"reference", {{"mode", "random-walk"}}}, {"test", {{"mode", "auto-0.05"}}}}};
  const Manifest m = f.parse(j);
  ASSERT_EQ(m.modes.size(), 5u);
  EXPECT_EQ(m.modes[0].name, "random-walk");
  EXPECT_EQ(m.modes[1].name, "auto-0.05");  // default name: "auto-" and the tolerance's shortest text
  EXPECT_EQ(m.modes[1].subsurface.name(), "auto");
  EXPECT_EQ(m.modes[1].subsurface.tolerance, 0.05);
  EXPECT_EQ(m.modes[2].name, "coarse");
  EXPECT_EQ(m.modes[2].subsurface.tolerance, 1.0);
  EXPECT_EQ(m.modes[3].name, "walk2");
  EXPECT_EQ(m.modes[3].subsurface.name(), "first-order");
  EXPECT_EQ(m.modes[4].name, "lambert");  // default name of a fixed mode: the mode
  const std::vector<BatchJob> jobs = expand_jobs(m);
  ASSERT_EQ(jobs.size(), 2u * 3u * 2u * 5u * 2u);
  EXPECT_EQ(jobs[2].id, "a__base__grey__auto-0.05__spp4");
  EXPECT_EQ(jobs[2].mode, "auto-0.05");
  EXPECT_EQ(jobs[2].subsurface.name(), "auto");
  EXPECT_EQ(jobs[2].subsurface.tolerance, 0.05);
  EXPECT_EQ(jobs[6].subsurface.name(), "first-order");
  EXPECT_EQ(jobs[6].subsurface.tolerance, 0.0);
  const std::vector<ComparisonPair> pairs = resolve_comparisons(m, jobs);
  ASSERT_EQ(pairs.size(), jobs.size() / 5);
  for (const ComparisonPair& p : pairs) {
    EXPECT_EQ(jobs[p.test].mode, "auto-0.05");
    EXPECT_EQ(jobs[p.reference].mode, "random-walk");
  }
  // A single object instead of a list.
  j = f.manifest();
  j["modes"] = {{"subsurface", "auto"}, {"tolerance", 0.25}};
  j.erase("comparisons");
  const Manifest single = f.parse(j);
  ASSERT_EQ(single.modes.size(), 1u);
  EXPECT_EQ(single.modes[0].name, "auto-0.25");
}

TEST(BatchManifest, AutoModeErrors) {
  Fixture f;
  auto with_mode = [&](const json& mode) {
    json j = f.manifest();
    j["modes"] = {"random-walk", mode};
    j.erase("comparisons");
    return j;
  };
  const json nan = std::numeric_limits<double>::quiet_NaN();
  const json inf = std::numeric_limits<double>::infinity();
  // The plain string "auto": the error shows the object form.
  expect_error(f, with_mode("auto"), "modes[1]", "needs a tolerance: write {\"subsurface\": \"auto\", \"tolerance\": 0.05}");
  expect_error(f, with_mode({{"subsurface", "auto"}}), "modes[1]", "needs a \"tolerance\"");
  for (const json& t : {json(0.0), json(-0.1), json(1.0000001), json(2), nan, inf, json("0.05"), json::array({0.05}), json(nullptr)}) {
    SCOPED_TRACE(t.dump());
    expect_error(f, with_mode({{"subsurface", "auto"}, {"tolerance", t}}), "modes[1].tolerance", "expected a relative error in (0, 1]");
  }
  expect_error(f, with_mode({{"subsurface", "table"}, {"tolerance", 0.05}}), "modes[1].tolerance", "only meaningful with");
  expect_error(f, with_mode({{"subsurface", "auto"}, {"tolerance", 0.05}, {"tolerence", 0.1}}), "modes[1].tolerence", "unknown key");
  expect_error(f, with_mode({{"subsurface", "photon"}}), "modes[1].subsurface", "unknown mode 'photon'");
  expect_error(f, with_mode({{"tolerance", 0.05}}), "modes[1]", "missing \"subsurface\"");
  expect_error(f, with_mode({{"subsurface", 3}}), "modes[1].subsurface", "expected a string");
  expect_error(f, with_mode(0.05), "modes[1]", "expected a mode name or an object");
  expect_error(f, with_mode({{"name", "a__b"}, {"subsurface", "auto"}, {"tolerance", 0.05}}), "modes[1].name", "__");
  expect_error(f, with_mode({{"name", "../x"}, {"subsurface", "auto"}, {"tolerance", 0.05}}), "modes[1].name", "letters");
  // Duplicate names: explicit, or a default name that another mode has.
  expect_error(f, with_mode({{"name", "random-walk"}, {"subsurface", "auto"}, {"tolerance", 0.05}}), "modes[1].name",
               "duplicate mode name 'random-walk'");
  expect_error(f, with_mode({{"subsurface", "random-walk"}}), "modes[1]", "duplicate mode name 'random-walk'");
  json j = f.manifest();
  j["modes"] = {{{"name", "a"}, {"subsurface", "auto"}, {"tolerance", 0.05}}, {{"name", "a"}, {"subsurface", "auto"}, {"tolerance", 0.1}}};
  j.erase("comparisons");
  expect_error(f, j, "modes[1].name", "duplicate mode name 'a'");
  // The same settings under two names would render the same image twice.
  j["modes"][1]["name"] = "b";
  j["modes"][1]["tolerance"] = 0.05;
  expect_error(f, j, "modes[1]", "renders the same as mode 'a'");
}

TEST(BatchManifest, LoadReportsFileErrors) {
  Fixture f;
  std::ofstream(f.dir / "bad.json") << "{ \"lamina_batch\": 1, ";
  EXPECT_THROW(load_manifest(f.dir / "bad.json"), ManifestError);
  try {
    load_manifest(f.dir / "bad.json");
  } catch (const ManifestError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json: malformed JSON: parse error at line"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_manifest(f.dir / "missing.json"), ManifestError);
  EXPECT_THROW(load_manifest(f.dir.path.string()), ManifestError);
}

TEST(BatchManifest, ExpansionIsTheProductInOrderWithUniqueIds) {
  Fixture f;
  const Manifest m = f.parse(f.manifest());
  const std::vector<BatchJob> jobs = expand_jobs(m);
  ASSERT_EQ(jobs.size(), 2u * 3u * 2u * 2u * 2u);
  std::set<std::string> ids, hashes;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    EXPECT_EQ(jobs[i].index, i);
    ids.insert(jobs[i].id);
    hashes.insert(jobs[i].hash);
  }
  EXPECT_EQ(ids.size(), jobs.size());
  // Every job differs in something that changes the image, except a and b, which are the same
  // scene written two ways (buffer embedded or beside the file): different bytes, different hash.
  EXPECT_EQ(hashes.size(), jobs.size());
  // Nesting: scene slowest, then variant, lighting, mode, spp fastest.
  EXPECT_EQ(jobs[0].id, "a__base__grey__random-walk__spp4");
  EXPECT_EQ(jobs[1].id, "a__base__grey__random-walk__spp16");
  EXPECT_EQ(jobs[2].id, "a__base__grey__lambert__spp4");
  EXPECT_EQ(jobs[4].id, "a__base__sky__random-walk__spp4");
  EXPECT_EQ(jobs[8].id, "a__thin__grey__random-walk__spp4");
  EXPECT_EQ(jobs[24].id, "b__base__grey__random-walk__spp4");
  EXPECT_EQ(jobs[4].env, "0.2,0.3,1.0");
  EXPECT_EQ(jobs[4].camera, "front");
  EXPECT_EQ(jobs[0].camera, "");
}

TEST(BatchManifest, HashesAreStableAndFollowWhatChangesTheImage) {
  Fixture f;
  const std::vector<BatchJob> a = expand_jobs(f.parse(f.manifest()));
  const std::vector<BatchJob> again = expand_jobs(f.parse(f.manifest()));
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].hash, again[i].hash);

  // Renaming changes ids but not hashes.
  json renamed = f.manifest();
  renamed["scenes"][0]["name"] = "quad";
  renamed["comparisons"] = json::array();
  const std::vector<BatchJob> r = expand_jobs(f.parse(renamed));
  EXPECT_EQ(r[0].id, "quad__base__grey__random-walk__spp4");
  EXPECT_EQ(r[0].hash, a[0].hash);

  // Each of these changes every hash of scene a.
  auto changed = [&](const json& j) {
    const std::vector<BatchJob> c = expand_jobs(f.parse(j));
    return c[0].hash != a[0].hash;
  };
  for (const char* key : {"width", "height", "seed", "max_depth"}) {
    json j = f.manifest();
    j["settings"][key] = j["settings"][key].get<int>() + 1;
    EXPECT_TRUE(changed(j)) << key;
  }
  json env = f.manifest();
  env["lighting"][0]["env"] = 1.5;
  EXPECT_TRUE(changed(env));
  // The scene file's contents (not its name) and its external buffer.
  testing::write_batch_quad(f.dir / "quad.gltf", "", 0.7f);
  EXPECT_TRUE(changed(f.manifest()));
  testing::write_batch_quad(f.dir / "quad.gltf");
  EXPECT_FALSE(changed(f.manifest()));
  const std::string b_hash = a[24].hash;
  std::ofstream(f.dir / "quad.bin", std::ios::app) << 'x';  // b's external buffer changes
  EXPECT_NE(expand_jobs(f.parse(f.manifest()))[24].hash, b_hash);
  // The mode: a fixed mode's hash is that of its --subsurface argument, whatever its name; auto
  // hashes its tolerance, so a new tolerance re-renders.
  auto first_hash = [&](const json& mode) {
    json j = f.manifest();
    j["modes"] = {mode};
    j.erase("comparisons");
    return expand_jobs(f.parse(j))[0].hash;
  };
  EXPECT_EQ(first_hash("random-walk"), a[0].hash);
  EXPECT_EQ(first_hash({{"name", "walk"}, {"subsurface", "random-walk"}}), a[0].hash);
  EXPECT_NE(first_hash("first-order"), a[0].hash);
  const std::string auto5 = first_hash({{"subsurface", "auto"}, {"tolerance", 0.05}});
  EXPECT_NE(auto5, a[0].hash);
  EXPECT_EQ(first_hash({{"name", "renamed"}, {"subsurface", "auto"}, {"tolerance", 0.05}}), auto5);
  EXPECT_NE(first_hash({{"subsurface", "auto"}, {"tolerance", 0.1}}), auto5);
  EXPECT_NE(first_hash({{"subsurface", "auto"}, {"tolerance", 0.05 * (1 + 1e-15)}}), auto5);
  // The stack's contents.
  json stack = testing::small_stack();
  stack["layers"][0]["g"] = 0.4;
  testing::write_json(f.dir / "stack.json", stack);
  EXPECT_TRUE(changed(f.manifest()));
}

TEST(BatchManifest, OverridesAndRenormalisation) {
  Fixture f;
  const Manifest m = f.parse(f.manifest());
  const std::vector<BatchJob> jobs = expand_jobs(m);
  const json& base = jobs[0].materials.at(0).stack;
  const json& thin = jobs[8].materials.at(0).stack;
  const json& blood = jobs[16].materials.at(0).stack;
  EXPECT_FALSE(jobs[0].materials[0].overridden);
  EXPECT_TRUE(jobs[8].materials[0].overridden);
  EXPECT_EQ(base, testing::small_stack());
  EXPECT_DOUBLE_EQ(thin["layers"][1]["thickness"].get<double>(), 0.2);
  // Fractions 0.1, 0.3, 0.6 with the first set to 0.05: the others scale by 0.95 / 0.9.
  const json& c = blood["layers"][1]["components"];
  EXPECT_DOUBLE_EQ(c[0]["fraction"].get<double>(), 0.05);
  EXPECT_NEAR(c[1]["fraction"].get<double>(), 0.3 * 0.95 / 0.9, 1e-15);
  EXPECT_NEAR(c[2]["fraction"].get<double>(), 0.6 * 0.95 / 0.9, 1e-15);
  EXPECT_NEAR(c[0]["fraction"].get<double>() + c[1]["fraction"].get<double>() + c[2]["fraction"].get<double>(), 1.0, 1e-15);
  // Without renormalise the sum is left as set (the stack loader rejects it later).
  json stack = testing::small_stack();
  apply_stack_override(stack, {"skin", "", {{"layers[1].components[0].fraction", 0.05}}, false}, "x");
  EXPECT_DOUBLE_EQ(stack["layers"][1]["components"][1]["fraction"].get<double>(), 0.3);
  // Setting every fraction: nothing left to rescale, so they must sum to 1.
  stack = testing::small_stack();
  EXPECT_THROW(apply_stack_override(stack, {"skin", "", {{"layers[1].components[0].fraction", 0.2}, {"layers[1].components[1].fraction", 0.2},
                                                         {"layers[1].components[2].fraction", 0.2}}, true}, "x"),
               ManifestError);
  // An RGB value and an "inf" thickness are accepted.
  stack = testing::small_stack();
  apply_stack_override(stack, {"skin", "", {{"layers[0].sigma_a", json::array({1, 2, 3})}, {"layers[1].thickness", "inf"}}, false}, "x");
  EXPECT_EQ(stack["layers"][0]["sigma_a"], json::array({1, 2, 3}));
  EXPECT_EQ(stack["layers"][1]["thickness"], "inf");
}

TEST(BatchManifest, ComparisonsPairEveryTestWithItsReference) {
  Fixture f;
  const Manifest m = f.parse(f.manifest());
  const std::vector<BatchJob> jobs = expand_jobs(m);
  const std::vector<ComparisonPair> pairs = resolve_comparisons(m, jobs);
  ASSERT_EQ(pairs.size(), jobs.size() / 2);  // every lambert job
  for (const ComparisonPair& p : pairs) {
    const BatchJob& r = jobs[p.reference];
    const BatchJob& t = jobs[p.test];
    EXPECT_EQ(t.mode, "lambert");
    EXPECT_EQ(r.mode, "random-walk");
    EXPECT_EQ(r.scene, t.scene);
    EXPECT_EQ(r.variant, t.variant);
    EXPECT_EQ(r.lighting, t.lighting);
    EXPECT_EQ(r.spp, t.spp);
    EXPECT_EQ(p.id, "lambert__" + t.id);
  }
  // Low spp against the highest, within one mode: the reference of a 16 spp job is itself,
  // so only the 4 spp jobs are tested.
  json j = f.manifest();
  j["comparisons"] = {{{"name", "noise"}, {"reference", {{"spp", 16}}}, {"test", {{"mode", "lambert"}}}}};
  const Manifest m2 = f.parse(j);
  const std::vector<ComparisonPair> p2 = resolve_comparisons(m2, expand_jobs(m2));
  ASSERT_EQ(p2.size(), jobs.size() / 4);
  for (const ComparisonPair& p : p2) EXPECT_EQ(jobs[p.test].spp, 4);
}

TEST(BatchManifest, ShardsPartitionTheJobs) {
  for (std::size_t count : {1u, 5u, 48u}) {
    for (int n = 1; n <= 7; ++n) {
      std::vector<int> owner(count, -1);
      std::vector<std::size_t> sizes(static_cast<std::size_t>(n), 0);
      for (int i = 0; i < n; ++i)
        for (std::size_t k = 0; k < count; ++k)
          if (in_shard(k, i, n)) {
            EXPECT_EQ(owner[k], -1) << "job " << k << " in shards " << owner[k] << " and " << i;
            owner[k] = i;
            ++sizes[static_cast<std::size_t>(i)];
          }
      for (std::size_t k = 0; k < count; ++k) EXPECT_GE(owner[k], 0) << "job " << k << " in no shard of " << n;
      const auto [lo, hi] = std::minmax_element(sizes.begin(), sizes.end());
      EXPECT_LE(*hi - *lo, 1u);
    }
  }
  EXPECT_EQ(parse_shard("2/5"), std::make_pair(2, 5));
  for (const char* bad : {"5/5", "1/0", "-1/3", "a/b", "3", "1/", "/2", "1/2/3"}) EXPECT_THROW(parse_shard(bad), std::invalid_argument) << bad;
}

TEST(BatchManifest, ContentHashIsFnv1a128) {
  // Published FNV-1a 128-bit values (the offset basis for "", and "a").
  EXPECT_EQ(content_hash(""), "6c62272e07bb014262b821756295c58d");
  EXPECT_EQ(content_hash("a"), "d228cb696f1a8caf78912b704e4a8964");
  EXPECT_NE(content_hash("ab"), content_hash("ba"));
}

TEST(ContactSheet, LayoutAndSize) {
  std::vector<ContactCell> cells(5, ContactCell{Image(40, 30), {"a", "b"}});
  cells[4].image = Image(40, 40);  // a square one makes every cell taller
  const ContactSheetLayout l = contact_sheet_layout(cells, 3, 80);
  EXPECT_EQ(l.columns, 3);
  EXPECT_EQ(l.rows, 2);
  EXPECT_EQ(l.cell_height, 80 + kSheetLabelLines * kSheetLineHeight);
  EXPECT_EQ(l.width, kSheetPadding + 3 * (80 + kSheetPadding));
  EXPECT_EQ(l.height, kSheetPadding + 2 * (l.cell_height + kSheetPadding));
  // A constant image stays constant when resized (the filter is normalised).
  for (ContactCell& c : cells) std::fill(c.image.rgb.begin(), c.image.rgb.end(), 0.5f);
  const Image sheet = make_contact_sheet(cells, 3, 80);
  ASSERT_EQ(sheet.width, l.width);
  ASSERT_EQ(sheet.height, l.height);
  EXPECT_NEAR(sheet.pixel(kSheetPadding + 40, kSheetPadding + 30)[1], 0.5f, 1e-5f);
  EXPECT_EQ(make_contact_sheet(cells, 3, 80).rgb, sheet.rgb);  // deterministic
  // Thumbnails average the area they cover: a 4 x 2 checkerboard of 0 and 1 halved is 0.5
  // everywhere, and a 3-pixel ramp 0, 1, 2 resized to 2 pixels gives (0 + 0.5) / 1.5 and
  // (0.5 + 2) / 1.5 (each thumbnail pixel covers 1.5 source pixels).
  Image checker(4, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) std::fill_n(checker.pixel(x, y), 3, static_cast<float>((x + y) % 2));
  const Image halved = make_contact_sheet({ContactCell{checker, {}}}, 1, 2);
  EXPECT_FLOAT_EQ(halved.pixel(kSheetPadding, kSheetPadding)[0], 0.5f);
  EXPECT_FLOAT_EQ(halved.pixel(kSheetPadding + 1, kSheetPadding)[2], 0.5f);
  Image ramp(3, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 3; ++x) std::fill_n(ramp.pixel(x, y), 3, static_cast<float>(x));
  const Image two = make_contact_sheet({ContactCell{ramp, {}}}, 1, 2);
  EXPECT_NEAR(two.pixel(kSheetPadding, kSheetPadding)[0], 0.5 / 1.5, 1e-6);
  EXPECT_NEAR(two.pixel(kSheetPadding + 1, kSheetPadding)[0], 2.5 / 1.5, 1e-6);
  EXPECT_THROW(contact_sheet_layout({}, 3, 80), std::invalid_argument);
}

TEST(BatchManifest, ExampleManifestsValidate) {
  const std::filesystem::path dir = std::filesystem::path(LAMINA_SOURCE_DIR) / "scenes" / "batch";
  std::size_t count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    SCOPED_TRACE(entry.path().string());
    const Manifest m = load_manifest(entry.path().string());
    const std::vector<BatchJob> jobs = expand_jobs(m);
    EXPECT_EQ(jobs.size(), m.scenes.size() * m.variants.size() * m.lighting.size() * m.modes.size() * m.spp.size());
    resolve_comparisons(m, jobs);
  }
  EXPECT_GE(count, 3u);
}

// A manifest's "camera" is checked against gltf_camera_names; every name the loader gives a
// camera or its node (what `lamina render --camera` matches) must be among them.
TEST(BatchManifest, CameraNamesIncludeTheLoadersNames) {
  Fixture f;
  testing::GltfBuilder b;
  b.add_node({{"mesh", b.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0}, {0, 1, 2})}});
  const json perspective = {{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.01}}}};
  json named = perspective, unnamed = perspective;
  named["name"] = "front";
  b.json()["cameras"] = {named, unnamed};
  b.add_node({{"name", "front_node"}, {"camera", 0}, {"translation", {0.0, 0.0, 3.0}}});
  b.add_node({{"name", "side_node"}, {"camera", 1}, {"translation", {3.0, 0.0, 0.0}}});
  b.write_gltf(f.dir / "cameras.gltf");
  const SceneDesc scene = load_gltf(f.dir / "cameras.gltf");
  const std::set<std::string> names = gltf_camera_names(read_gltf_json(f.dir / "cameras.gltf"));
  ASSERT_EQ(scene.cameras.size(), 2u);
  EXPECT_EQ(scene.cameras[0].name, "front");
  EXPECT_EQ(scene.cameras[1].name, "side_node");  // unnamed: its node's name
  for (const CameraDesc& c : scene.cameras) {
    EXPECT_EQ(names.count(c.name), 1u) << c.name;
    EXPECT_EQ(names.count(c.node_name), 1u) << c.node_name;
  }
  EXPECT_EQ(names, (std::set<std::string>{"front", "front_node", "side_node"}));
}

}  // namespace
}  // namespace lamina
