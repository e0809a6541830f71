// Fitting a measured reflectance spectrum with a stack given by chromophores (`lamina fit
// --spectrum`; docs/spectral.md, "Fitting a measured skin spectrum"): a few chromophore
// parameters (at most kMaxSpectralParameters) chosen so that the adding-doubling total
// reflectance R = R_specular + R_diffuse at each measured wavelength, for collimated light at
// theta_i, is closest to the measurement in the least-squares sense: Levenberg-Marquardt on the
// parameters scaled to [0, 1] by their bounds, searching on a coarse quadrature first
// (spectral_fit.cpp; docs/spectral.md, "Fitting a measured skin spectrum", has its cost).
#pragma once

#include <string>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/fit/stack_fit.h"
#include "materials/stack/spectral_stack.h"

namespace lamina {

constexpr int kMaxSpectralParameters = 5;

// PATH of a chromophore parameter: "layers[i].chromophores.KEY" with KEY one of melanin,
// eumelanin, blood, oxygenation, water, fat, carotene, baseline, g, or
// "layers[i].chromophores.scattering.KEY" with KEY reduced_500, f_rayleigh or b_mie. Returns the
// number it names in *stack; throws FitError naming the path when it names nothing.
double* chromophore_parameter(SpectralStack* stack, const std::string& path);

struct SpectralFitResult {
  std::vector<double> values;             // per parameter, in the order given
  std::vector<double> nm, measured, modelled;
  double rmse = 0.0;                      // sqrt(mean (modelled - measured)^2)
  int evaluations = 0;                    // spectra solved (accurate and coarse)
  int coarse_evaluations = 0;             // of which on the coarse model
  SpectralStack fitted;
};

// The search runs on the model at coarse_quadrature_points (when at least 2 and below
// settings.quadrature_points; else on the accurate model alone), then on the accurate model from
// its optimum. Throws FitError for a bad path, more than kMaxSpectralParameters parameters,
// lower >= upper, or wavelengths and measurements of different lengths.
SpectralFitResult fit_spectrum(const SpectralStack& start, const std::vector<FitParameterSpec>& parameters,
                               const std::vector<double>& nm, const std::vector<double>& measured, double cos_theta_i,
                               const AddingDoublingSettings& settings = {}, int coarse_quadrature_points = 4);

// Leaves (docs/spectral.md, "A rough cuticle"): the total reflectance
// R_specular + R_diffuse and transmittance T_ballistic + T_diffuse of several stacks at each
// wavelength, for collimated light at each cos_theta_i, averaged with `weights` (summing to 1:
// the incident cone of scripts/leaf_fit.py). An energy-conserving rough interface is projected
// anew for every wavelength (its index and nodes follow the leaf's index), hundreds of times a
// smooth solution's cost; adding_doubling_totals keeps its last projections by their exact
// inputs, so the loop runs wavelength by wavelength, each wavelength's stacks and incidences in
// a row: stacks that share their interfaces (the same roughness, leaf layers, layer order) and
// differ in contents and scattering project each rough interface once per wavelength, however
// many stacks and incidences. r[k][i], t[k][i]: stack k at nm[i]. Throws std::invalid_argument
// for empty or unequal cos_theta_i and weights.
struct LeafSpectra {
  std::vector<std::vector<double>> r, t;
};
LeafSpectra leaf_spectra(const std::vector<SpectralStack>& stacks, const std::vector<double>& nm,
                         const std::vector<double>& cos_theta_i, const std::vector<double>& weights,
                         const AddingDoublingSettings& settings = {});

// The modelled total reflectance R_specular + R_diffuse at each wavelength.
std::vector<double> modelled_reflectance(const SpectralStack& stack, const std::vector<double>& nm, double cos_theta_i,
                                         const AddingDoublingSettings& settings = {});

}  // namespace lamina
