// lamina fit --spectrum: chromophore parameters of a material file fitted to a measured
// reflectance spectrum (docs/spectral.md, "Fitting a measured skin spectrum"). Called by run_fit
// once its options are parsed.
#pragma once

#include <string>
#include <vector>

#include "materials/fit/stack_fit.h"

namespace lamina::cli {

struct SpectralFitRequest {
  std::string stack_path, spectrum_path, column, summary_path;
  std::vector<FitParameterSpec> parameters;
  double theta_i_deg = 8.0;
  int quadrature_points = 16;
  int coarse_quadrature_points = 4;  // the search's model (materials/fit/spectral_fit.h); 0: none
};

// Returns the exit status; errors are one line on stderr.
int run_fit_spectral(const SpectralFitRequest& request);

}  // namespace lamina::cli
