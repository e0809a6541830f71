#include "materials/adding_doubling/spectral_totals.h"

#include <tbb/parallel_for.h>

namespace lamina {

// Wavelengths are independent solutions: in parallel, each into its own slot (the result does
// not depend on the thread count).
SpectralTotals adding_doubling_spectrum(const SpectralStack& stack, const WavelengthGrid& grid, double cos_theta_i,
                                        AddingDoublingSettings settings) {
  settings.only_channel = 0;  // a grey stack: one channel says it all
  SpectralTotals out;
  out.nm.resize(static_cast<std::size_t>(grid.count));
  out.estimates.resize(out.nm.size());
  tbb::parallel_for(0, grid.count, [&](int i) {
    out.nm[static_cast<std::size_t>(i)] = grid.at(i);
    out.estimates[static_cast<std::size_t>(i)] =
        adding_doubling_with_error(stack_at_wavelength(stack, grid.at(i)), cos_theta_i, settings);
  });
  return out;
}

}  // namespace lamina
