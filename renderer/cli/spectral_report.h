// What `lamina brdf --wavelengths` and `lamina fit --spectrum` share in their reports: the colour
// of a spectrum as a JSON triple, and writing the report to its file or stdout.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "materials/spectral/colour.h"
#include "renderer/cli/outputs.h"
#include "renderer/util/atomic_file.h"

namespace lamina::cli {

// Linear Rec. 709 of a reflectance or transmittance given at nm (linear between the samples,
// held beyond them) lit by D65.
inline nlohmann::ordered_json rec709_json(const std::vector<double>& nm, const std::vector<double>& values) {
  const Spectrum rgb = reflectance_to_linear_rec709(TabulatedSpectrum(nm, values));
  return {rgb[0], rgb[1], rgb[2]};
}

// The report to summary_path (written whole or not at all) or, without one, to stdout.
inline void write_report(const std::string& summary_path, const std::string& json) {
  if (summary_path.empty()) {
    std::fputs(json.c_str(), stdout);
    return;
  }
  StagedOutputs outputs;
  outputs.write(summary_path, [&](const std::string& tmp) { write_file_atomically(tmp, json); });
  outputs.commit();
}

}  // namespace lamina::cli
