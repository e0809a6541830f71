#include "renderer/layered/subsurface_mode.h"

#include <iterator>

namespace lamina {

bool parse_subsurface_mode(const std::string& name, SubsurfaceMode* mode) {
  for (const SubsurfaceModeNames& m : kSubsurfaceModes)
    if (name == m.name) {
      *mode = m.mode;
      return true;
    }
  return false;
}

const char* subsurface_mode_name(SubsurfaceMode mode) {
  for (const SubsurfaceModeNames& m : kSubsurfaceModes)
    if (m.mode == mode) return m.name;
  return "?";
}

const char* subsurface_mode_short_name(SubsurfaceMode mode) {
  for (const SubsurfaceModeNames& m : kSubsurfaceModes)
    if (m.mode == mode) return m.short_name;
  return "?";
}

std::string subsurface_mode_names(const std::string& separator, const std::string& last_separator) {
  std::string s;
  const std::size_t n = std::size(kSubsurfaceModes);
  for (std::size_t i = 0; i < n; ++i) s += (i == 0 ? "" : i + 1 == n ? last_separator : separator) + kSubsurfaceModes[i].name;
  return s;
}

std::string subsurface_mode_names(const std::string& separator) { return subsurface_mode_names(separator, separator); }

bool parse_subsurface_choice(const std::string& name, SubsurfaceChoice* choice) {
  SubsurfaceChoice c;
  if (name == kAutoSubsurfaceName) c.automatic = true;
  else if (!parse_subsurface_mode(name, &c.mode)) return false;
  *choice = c;
  return true;
}

std::string subsurface_choice_expected() { return subsurface_mode_names(", ") + " or " + kAutoSubsurfaceName; }

}  // namespace lamina
