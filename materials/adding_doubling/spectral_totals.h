// Adding-doubling one wavelength at a time: the totals of a stack whose layers are given by
// chromophores (materials/stack/spectral_stack.h) on a grid of wavelengths (`lamina brdf
// --wavelengths`; docs/spectral.md). Each wavelength is the grey stack stack_at_wavelength
// gives, solved in one channel (AddingDoublingSettings::only_channel 0).
#pragma once

#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/spectral/wavelength_grid.h"
#include "materials/stack/spectral_stack.h"

namespace lamina {

struct SpectralTotals {
  std::vector<double> nm;
  // Per wavelength: the totals and their discretisation error (adding_doubling_with_error); the
  // value is channel 0 of each Spectrum.
  std::vector<AddingDoublingEstimate> estimates;
};

SpectralTotals adding_doubling_spectrum(const SpectralStack& stack, const WavelengthGrid& grid, double cos_theta_i,
                                        AddingDoublingSettings settings = {});

}  // namespace lamina
