// Lamina's version: CMake's project(VERSION), the one place it is written. It is printed by
// `lamina --version`, written to every EXR (lamina:version), and part of batch job hashes and
// walk-cache keys, so a new version re-renders a batch and rebuilds cached results.
#pragma once

namespace lamina {

const char* lamina_version();
// The commit the build was configured from (`git describe`), "unknown" outside git: printed by
// `lamina --version` only, never hashed (a rebuild from another commit must not re-render).
const char* lamina_commit();

}  // namespace lamina
