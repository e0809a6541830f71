// One key of an EXR's header, as the CLI tests read what a render or a batch job wrote.
#pragma once

#include <string>

#include "renderer/image/image_io.h"

namespace lamina::test {

// The value of `key` in the header of `exr`, or "" if the header has no such key.
inline std::string exr_header(const std::string& exr, const std::string& key) {
  for (const auto& [k, v] : read_metadata(exr))
    if (k == key) return v;
  return "";
}

}  // namespace lamina::test
