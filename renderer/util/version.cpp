#include "renderer/util/version.h"

#if !defined(LAMINA_VERSION) || !defined(LAMINA_COMMIT)
#error "LAMINA_VERSION and LAMINA_COMMIT must be defined by the build (renderer/util/CMakeLists.txt)"
#endif

namespace lamina {

// LAMINA_VERSION and LAMINA_COMMIT are defined for this file only (renderer/util/CMakeLists.txt).
const char* lamina_version() { return LAMINA_VERSION; }
const char* lamina_commit() { return LAMINA_COMMIT; }

}  // namespace lamina
