// Denoising as a post-process (lamina denoise): Intel Open Image Denoise's "RT" filter on a
// rendered image, guided by the albedo and normal AOVs when the EXR has them. The raw render is
// never replaced: the denoised image is a new file.
//
// Why a run-time binding: Debian bookworm has no OIDN package, and PyPI's pyoidn (pinned in
// scripts/setup.sh) ships the library without headers. The library's C API is small and stable
// (oidn.h of OIDN 2.x: devices, filters, shared images), so Lamina declares the handful of
// functions it calls and loads the library with dlopen when `lamina denoise` runs. Nothing else
// links it: a build and every render work without it, and the render path never touches it.
#pragma once

#include <stdexcept>
#include <string>

#include "renderer/image/image.h"

namespace lamina {

struct DenoiseError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Where the library is looked for: $LAMINA_OIDN_LIBRARY if set (only there); otherwise the
// pyoidn install that CMake found at configure time (LAMINA_OIDN_DEFAULT), then
// libOpenImageDenoise.so.2 on the loader's path.
std::string oidn_library_candidates();

struct DenoiseInput {
  const Image* colour = nullptr;  // linear HDR radiance
  const Image* albedo = nullptr;  // optional: [0, 1] (clamped here)
  const Image* normal = nullptr;  // optional, and only with an albedo: any length, [-1, 1]
  int threads = 0;                // 0: OIDN's default (all cores)
};

struct DenoiseResult {
  Image image;
  std::string library;  // the file that was loaded
  int version = 0;      // OIDN's version number, e.g. 20501
};

// Throws DenoiseError (one line) if the library cannot be loaded or reports an error.
DenoiseResult denoise(const DenoiseInput& input);

}  // namespace lamina
