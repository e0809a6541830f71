// The --subsurface shading modes of layered materials and their names on the command line.
#pragma once

#include <string>

namespace lamina {

// How layered materials are shaded (docs/contracts.md, `lamina render --subsurface`).
enum class SubsurfaceMode { RandomWalk, FirstOrder, Table, Lambert };
// Parses "random-walk" | "first-order" | "table" | "lambert"; false if unknown.
bool parse_subsurface_mode(const std::string& name, SubsurfaceMode* mode);
const char* subsurface_mode_name(SubsurfaceMode mode);

}  // namespace lamina
