#include "materials/stack/spectral_stack.h"

namespace lamina {

LayerStack stack_at_wavelength(const SpectralStack& spectral, double nm) {
  LayerStack s = spectral.stack;
  for (std::size_t i = 0; i < s.layers.size() && i < spectral.chromophores.size(); ++i) {
    const std::optional<SkinChromophores>& c = spectral.chromophores[i];
    if (!c) continue;
    s.layers[i].sigma_a = Spectrum(c->absorption(nm));
    s.layers[i].lobes = {PhaseLobe{Spectrum(c->scattering_coefficient(nm)), Spectrum(c->g)}};
  }
  return s;
}

}  // namespace lamina
