// The tables that declare the subsurface choice and the walk options once
// (renderer/layered/subsurface_mode.h, renderer/render/walk_option_table.h): every name and
// value reads back, and what the batch passes to `lamina render` is what the table declares.
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/layered/subsurface_mode.h"
#include "renderer/render/walk_option_table.h"

namespace lamina {
namespace {

TEST(SubsurfaceChoice, EveryModeNameReadsBack) {
  std::set<std::string> names, short_names;
  for (const SubsurfaceModeNames& m : kSubsurfaceModes) {
    SubsurfaceChoice c;
    ASSERT_TRUE(parse_subsurface_choice(m.name, &c)) << m.name;
    EXPECT_FALSE(c.automatic);
    EXPECT_EQ(c.mode, m.mode);
    EXPECT_EQ(c.name(), m.name);
    EXPECT_STREQ(subsurface_mode_short_name(m.mode), m.short_name);
    names.insert(m.name);
    short_names.insert(m.short_name);
  }
  EXPECT_EQ(names.size(), std::size(kSubsurfaceModes));  // no two modes share a name
  EXPECT_EQ(short_names.size(), std::size(kSubsurfaceModes));
  EXPECT_EQ(names.count(kAutoSubsurfaceName), 0u);
}

TEST(SubsurfaceChoice, AutoAndUnknownNames) {
  SubsurfaceChoice c = SubsurfaceChoice::fixed(SubsurfaceMode::Table);
  ASSERT_TRUE(parse_subsurface_choice("auto", &c));
  EXPECT_TRUE(c.automatic);
  EXPECT_EQ(c.name(), "auto");
  SubsurfaceMode mode = SubsurfaceMode::Lambert;
  EXPECT_FALSE(parse_subsurface_mode("auto", &mode));  // auto is a choice, not a mode
  EXPECT_EQ(mode, SubsurfaceMode::Lambert);
  EXPECT_FALSE(parse_subsurface_choice("dipole", &c));
  EXPECT_TRUE(c.automatic);  // unchanged on failure
  // The messages the CLI and the manifests print (the hostile-input corpus depends on them).
  EXPECT_EQ(subsurface_choice_expected(), "random-walk, first-order, table, lambert or auto");
  EXPECT_EQ(subsurface_mode_names("|"), "random-walk|first-order|table|lambert");
  // Equal choices render the same image: fixed modes by mode, auto by tolerance.
  EXPECT_EQ(SubsurfaceChoice::automatic_within(0.05), SubsurfaceChoice::automatic_within(0.05));
  EXPECT_FALSE(SubsurfaceChoice::automatic_within(0.05) == SubsurfaceChoice::automatic_within(0.1));
  EXPECT_FALSE(SubsurfaceChoice::fixed(SubsurfaceMode::Table) == SubsurfaceChoice::fixed(SubsurfaceMode::Lambert));
}

TEST(WalkOptionTable, KeysAndFlagsAreUniqueAndInHeaderOrder) {
  std::vector<std::string> keys;
  std::set<std::string> flags;
  for (const WalkOptionSpec& spec : kWalkOptionTable) {
    keys.push_back(spec.exr_key);
    flags.insert(spec.flag);
    EXPECT_EQ(std::string(spec.flag).rfind("--", 0), 0u) << spec.flag;
    EXPECT_EQ(std::string(spec.exr_key).rfind("lamina:", 0), 0u) << spec.exr_key;
  }
  EXPECT_EQ(flags.size(), kWalkOptionTable.size());
  // The EXR header's order (docs/contracts.md): a reordered table would reorder the header.
  EXPECT_EQ(keys, (std::vector<std::string>{"lamina:pool_samples", "lamina:similarity_after", "lamina:guiding",
                                            "lamina:next_flight"}));
}

TEST(WalkOptionTable, DefaultsAreTheRenderersAndPassNoArguments) {
  const RandomWalkOptions walk;
  EXPECT_EQ(walk.roulette_threshold, 0.5);  // the renderer's preset, not the library's 0.01
  EXPECT_EQ(walk.roulette_survival, 0.5);
  EXPECT_EQ(WalkOptions{}.roulette_threshold, 0.01);
  EXPECT_EQ(WalkOptions{}.roulette_survival, 0.1);
  std::vector<std::string> texts;
  for (const WalkOptionSpec& spec : kWalkOptionTable) texts.push_back(walk_option_text(spec, walk));
  EXPECT_EQ(texts, (std::vector<std::string>{"shared", "-1", "0", "on"}));
  EXPECT_TRUE(walk_option_arguments(walk).empty());
}

TEST(WalkOptionTable, ChangedOptionsBecomeArguments) {
  RandomWalkOptions walk;
  walk.guiding = 0.1;  // not exact in binary: printed so that it reads back
  walk.next_flight = false;
  walk.similarity_after = 3;
  EXPECT_EQ(walk_option_arguments(walk),
            (std::vector<std::string>{"--similarity-after", "3", "--guiding", "0.10000000000000001", "--next-flight", "off"}));
  RandomWalkOptions read;
  for (const WalkOptionSpec& spec : kWalkOptionTable)
    if (spec.kind == WalkOptionSpec::Kind::Switch) {
      EXPECT_TRUE(set_walk_switch(spec, walk_option_text(spec, walk), &read)) << spec.flag;
      EXPECT_FALSE(set_walk_switch(spec, "maybe", &read)) << spec.flag;
    }
  EXPECT_FALSE(read.next_flight);
  EXPECT_FALSE(read.per_event_pool_samples);
  EXPECT_EQ(std::stod(walk_option_text(kWalkOptionTable[2], walk)), walk.guiding);
}

}  // namespace
}  // namespace lamina
