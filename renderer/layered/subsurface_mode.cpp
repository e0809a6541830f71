#include "renderer/layered/subsurface_mode.h"

namespace lamina {

bool parse_subsurface_mode(const std::string& name, SubsurfaceMode* mode) {
  if (name == "random-walk") *mode = SubsurfaceMode::RandomWalk;
  else if (name == "first-order") *mode = SubsurfaceMode::FirstOrder;
  else if (name == "table") *mode = SubsurfaceMode::Table;
  else if (name == "lambert") *mode = SubsurfaceMode::Lambert;
  else return false;
  return true;
}

const char* subsurface_mode_name(SubsurfaceMode mode) {
  switch (mode) {
    case SubsurfaceMode::RandomWalk: return "random-walk";
    case SubsurfaceMode::FirstOrder: return "first-order";
    case SubsurfaceMode::Table: return "table";
    case SubsurfaceMode::Lambert: return "lambert";
  }
  return "?";
}

}  // namespace lamina
