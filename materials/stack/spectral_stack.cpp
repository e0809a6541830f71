#include "materials/stack/spectral_stack.h"

#include <algorithm>

namespace lamina {

LayerStack stack_at_wavelength(const SpectralStack& spectral, double nm) {
  LayerStack s = spectral.stack;
  for (std::size_t i = 0; i < s.layers.size() && i < spectral.chromophores.size(); ++i) {
    const std::optional<SkinChromophores>& c = spectral.chromophores[i];
    if (!c) continue;
    s.layers[i].sigma_a = Spectrum(c->absorption(nm));
    s.layers[i].lobes = {PhaseLobe{Spectrum(c->scattering_coefficient(nm)), Spectrum(c->g)}};
  }
  for (std::size_t i = 0; i < s.layers.size() && i < spectral.leaves.size(); ++i) {
    const std::optional<LeafChromophores>& leaf = spectral.leaves[i];
    if (!leaf) continue;
    Layer& layer = s.layers[i];
    layer.ior = LeafChromophores::refractive_index(nm);
    layer.sigma_a = Spectrum(leaf->absorption(nm, layer.thickness));
    layer.lobes = {PhaseLobe{Spectrum(leaf->scattering_coefficient(nm, layer.thickness)), Spectrum(leaf->g)}};
  }
  return s;
}

SpectralStack flipped(const SpectralStack& spectral) {
  SpectralStack s = spectral;
  s.stack = flipped(spectral.stack);
  std::reverse(s.chromophores.begin(), s.chromophores.end());
  std::reverse(s.leaves.begin(), s.leaves.end());
  return s;
}

}  // namespace lamina
