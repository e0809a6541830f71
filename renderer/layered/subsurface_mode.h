// The --subsurface shading modes of layered materials, their names, and the subsurface choice of
// a render (a mode, or auto with its tolerance): the one table of mode names that the command
// line, the batch manifests, the contact sheets and the EXR metadata all read. A new mode is one
// enumerator and one row of kSubsurfaceModes.
#pragma once

#include <string>

namespace lamina {

// How layered materials are shaded (docs/contracts.md, `lamina render --subsurface`).
enum class SubsurfaceMode { RandomWalk, FirstOrder, Table, Lambert };

// A mode's names: on the command line, in manifests and headers (`name`), and on a contact
// sheet's labels, where a cell is ~160 px wide (`short_name`).
struct SubsurfaceModeNames {
  SubsurfaceMode mode;
  const char* name;
  const char* short_name;
};
inline constexpr SubsurfaceModeNames kSubsurfaceModes[] = {
    {SubsurfaceMode::RandomWalk, "random-walk", "walk"},
    {SubsurfaceMode::FirstOrder, "first-order", "1st"},
    {SubsurfaceMode::Table, "table", "table"},
    {SubsurfaceMode::Lambert, "lambert", "lamb"},
};
// The choice that is not a mode: a mode per material, the cheapest whose predicted error is
// within a tolerance (renderer/layered/subsurface_auto.h).
inline constexpr const char* kAutoSubsurfaceName = "auto";
// What auto records for a material that camera rays do not see: not predicted, shaded as
// lambert (the header's lamina:auto_mode:<material>).
inline constexpr const char* kHiddenAutoModeName = "lambert-hidden";

// Parses a mode's name; false if unknown ("auto" is not a mode).
bool parse_subsurface_mode(const std::string& name, SubsurfaceMode* mode);
const char* subsurface_mode_name(SubsurfaceMode mode);
const char* subsurface_mode_short_name(SubsurfaceMode mode);
// The modes' names joined for messages and help: ("|") -> "random-walk|first-order|table|lambert";
// (", ", " or ") -> "random-walk, first-order, table or lambert".
std::string subsurface_mode_names(const std::string& separator, const std::string& last_separator);
std::string subsurface_mode_names(const std::string& separator);

// How a render shades its layered materials: one mode for all, or auto within a tolerance.
struct SubsurfaceChoice {
  bool automatic = false;
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;  // when not automatic
  double tolerance = 0.0;  // when automatic: the largest predicted relative error per material, in (0, 1]

  static SubsurfaceChoice fixed(SubsurfaceMode m) { return {false, m, 0.0}; }
  static SubsurfaceChoice automatic_within(double tolerance) { return {true, SubsurfaceMode::RandomWalk, tolerance}; }
  // The --subsurface argument: the mode's name or "auto".
  std::string name() const { return automatic ? kAutoSubsurfaceName : subsurface_mode_name(mode); }
  bool operator==(const SubsurfaceChoice& o) const {
    return automatic == o.automatic && (automatic ? tolerance == o.tolerance : mode == o.mode);
  }
};
// Parses a --subsurface argument, a mode's name or "auto" (whose tolerance is the caller's to
// set); false if neither.
bool parse_subsurface_choice(const std::string& name, SubsurfaceChoice* choice);
// What a parse failure expects: "random-walk, first-order, table, lambert or auto".
std::string subsurface_choice_expected();

}  // namespace lamina
