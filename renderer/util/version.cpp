#include "renderer/util/version.h"

#ifndef LAMINA_VERSION
#error "LAMINA_VERSION must be defined by the build (renderer/util/CMakeLists.txt)"
#endif

namespace lamina {

// LAMINA_VERSION is defined for this file only (renderer/util/CMakeLists.txt).
const char* lamina_version() { return LAMINA_VERSION; }

}  // namespace lamina
