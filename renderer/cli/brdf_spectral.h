// lamina brdf --wavelengths: the adding-doubling totals of a material file per wavelength
// (docs/spectral.md, "lamina brdf per wavelength"). Called by run_brdf once its options are parsed.
#pragma once

#include <string>

namespace lamina::cli {

struct SpectralBrdfRequest {
  std::string stack_path, summary_path, wavelengths;  // wavelengths: "FIRST:LAST:STEP" in nm
  double theta_i_deg = 0.0, phi_i_deg = 0.0;
  int quadrature_points = 16;
};

// Parses "FIRST:LAST:STEP" (250 <= FIRST <= LAST <= 2500, STEP > 0, at most 10000 wavelengths);
// throws UsageError naming --wavelengths.
void check_wavelengths(const std::string& text);

// Loads the stack (chromophore layers allowed), solves each wavelength, writes the JSON (to
// summary_path or stdout). Returns the exit status; errors are one line on stderr.
int run_brdf_spectral(const SpectralBrdfRequest& request);

}  // namespace lamina::cli
