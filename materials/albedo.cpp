#include "materials/albedo.h"

#include <algorithm>
#include <cmath>

#include "materials/random_walk.h"
#include "materials/sampling.h"

namespace lamina {

Spectrum diffuse_bihemispherical_albedo(const LayerStack& stack, int walks, std::uint64_t seed,
                                        Spectrum* standard_error) {
  // Cosine-weighted incidence: mu_i = sqrt(u) has density 2 mu_i on [0, 1], so
  // E[top exit weight after >= 1 scattering] = int_0^1 R_diffuse(mu) 2 mu dmu, the white-sky
  // albedo. The walk's weight is per unit incident power and excludes the top's specular part.
  Spectrum sum(0.0), sum2(0.0);
  for (int i = 0; i < walks; ++i) {
    Rng rng(seed, static_cast<std::uint64_t>(i), 0x1a3b);
    const double mu = std::sqrt(std::max(rng.uniform(), 1e-300));
    const double phi = 2.0 * kPi * rng.uniform();
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    const WalkResult r = random_walk(stack, {s * std::cos(phi), s * std::sin(phi), mu}, rng);
    if (r.side == WalkResult::Side::Top && r.scatter_count > 0) {
      sum += r.weight;
      sum2 += r.weight * r.weight;
    }
  }
  const double n = std::max(1, walks);
  const Spectrum mean = sum / n;
  if (standard_error) {
    for (int c = 0; c < kChannels; ++c)
      (*standard_error)[c] = std::sqrt(std::max(0.0, sum2[c] / n - mean[c] * mean[c]) / std::max(1.0, n - 1.0));
  }
  return mean;
}

}  // namespace lamina
