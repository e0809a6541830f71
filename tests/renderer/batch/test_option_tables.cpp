// The tables that declare the subsurface choice, the walk options and lamina brdf's options
// once (renderer/layered/subsurface_mode.h, renderer/render/walk_option_table.h,
// renderer/batch/brdf_job.h): every name and value reads back, and what the batch passes to
// `lamina render` is what the table declares. And the rules that combine a render's options
// (renderer/render/render_request_check.h), which every caller of render_job shares.
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/batch/brdf_job.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/render/render_request_check.h"
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

// Each row sets its own member (and no other's), its keyword is its flag without dashes, and the
// defaults are BrdfRequest's.
TEST(BrdfOptionTable, EveryRowSetsItsOwnMember) {
  std::set<std::string> flags, keywords;
  const BrdfRequest defaults;
  for (const BrdfOptionSpec& spec : kBrdfOptionTable) {
    flags.insert(spec.flag);
    keywords.insert(brdf_option_keyword(spec));
    std::string flag = "--" + brdf_option_keyword(spec);
    for (char& c : flag) c = c == '_' ? '-' : c;
    EXPECT_EQ(flag, spec.flag);
    EXPECT_EQ(brdf_option_keyword(spec).find('-'), std::string::npos);
    BrdfRequest r;
    switch (spec.kind) {
      case BrdfOptionSpec::Kind::Real: *spec.real(&r) = 12.5; break;
      case BrdfOptionSpec::Kind::Integer: *spec.integer(&r) = 1234; break;
      case BrdfOptionSpec::Kind::Count:
      case BrdfOptionSpec::Kind::Seed: *spec.count(&r) = 98765; break;
      case BrdfOptionSpec::Kind::Method: r.method = BrdfMethod::AddingDoubling; break;
    }
    for (const BrdfOptionSpec& other : kBrdfOptionTable) {
      const std::string text = brdf_option_text(other, r);
      if (&other == &spec)
        EXPECT_NE(text, brdf_option_text(other, defaults)) << spec.flag;
      else
        EXPECT_EQ(text, brdf_option_text(other, defaults)) << spec.flag << " changed " << other.flag;
    }
  }
  EXPECT_EQ(flags.size(), kBrdfOptionTable.size());
  EXPECT_EQ(keywords.size(), kBrdfOptionTable.size());
  EXPECT_EQ(brdf_option_text(kBrdfOptionTable[0], defaults), "0");  // --theta-i: required, listed first
  EXPECT_TRUE(kBrdfOptionTable[0].required);
}

TEST(BrdfOptionTable, TheBinsProductIsChecked) {
  BrdfRequest r;
  r.options.bins_theta = 1000;
  r.options.bins_phi = 1000;
  EXPECT_NO_THROW(check_brdf_request(r));
  r.options.bins_phi = 1001;
  EXPECT_THROW(check_brdf_request(r), std::invalid_argument);
}

std::string refusal(const RenderRequest& r) {
  try {
    check_render_request(r);
  } catch (const RenderRequestError& e) {
    return e.what();
  }
  return "";
}

// Each rule refuses an option given where it would not act, and lets the same option pass with
// what it needs; an option left at its default (not given) never trips a rule.
TEST(RenderRequestCheck, OptionsThatWouldNotActAreRefused) {
  RenderRequest r;
  r.settings.width = 40;
  r.settings.height = 30;
  EXPECT_EQ(refusal(r), "");
  r.given = {"--exposure"};
  EXPECT_EQ(refusal(r), "--exposure is only meaningful with --png (the EXR stays linear)");
  r.png_path = "x.png";
  EXPECT_EQ(refusal(r), "");
  r.given = {"--guiding"};
  r.subsurface = SubsurfaceChoice::fixed(SubsurfaceMode::Lambert);
  EXPECT_EQ(refusal(r), "--guiding is only meaningful with --subsurface random-walk or auto (the lambert mode runs no walk)");
  r.subsurface = SubsurfaceChoice::automatic_within(0.05);
  EXPECT_EQ(refusal(r), "");
  r.given = {};
  r.subsurface = SubsurfaceChoice::automatic_within(0.0);
  EXPECT_EQ(refusal(r), "--subsurface auto needs --tolerance E (e.g. 0.05)");
  r.subsurface = SubsurfaceChoice::fixed(SubsurfaceMode::RandomWalk);
  r.given = {"--tolerance"};
  EXPECT_EQ(refusal(r), "--tolerance is only meaningful with --subsurface auto");
  r.given = {"--table-method"};
  EXPECT_EQ(refusal(r), "--table-method is only meaningful with --subsurface table or auto");
  r.subsurface = SubsurfaceChoice::fixed(SubsurfaceMode::Table);
  EXPECT_EQ(refusal(r), "");
  r.given = {"--pilot-spp"};
  EXPECT_EQ(refusal(r), "--pilot-spp is only meaningful with --noise-threshold");
  r.settings.noise_threshold = 0.1;
  r.settings.pilot_spp = 32;
  EXPECT_EQ(refusal(r), "--pilot-spp 32 exceeds --spp 16");
}

TEST(RenderRequestCheck, SizeAndCrop) {
  RenderRequest r;
  r.settings.width = 40;
  r.settings.height = 30;
  r.given = {"--crop"};  // a given crop of nothing is refused, not read as the whole image
  EXPECT_EQ(refusal(r), "--crop 0,0,0,0: expected X0 < X1 <= --width (40) and Y0 < Y1 <= --height (30)");
  r.settings.crop = PixelRegion{10, 5, 40, 30};
  EXPECT_EQ(refusal(r), "");
  r.given = {};
  r.settings.crop = PixelRegion{10, 5, 41, 30};  // set without being "given" (another caller): still checked
  EXPECT_NE(refusal(r), "");
  r.settings.crop = {};
  r.settings.width = r.settings.height = 16384;
  r.settings.spp = 1 << 20;
  EXPECT_EQ(refusal(r), "--width x --height x --spp exceeds 1e12 paths");
}

}  // namespace
}  // namespace lamina
