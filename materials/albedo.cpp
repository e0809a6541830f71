#include "materials/albedo.h"

#include <algorithm>
#include <cmath>

#include "materials/random_walk.h"
#include "materials/sampling.h"

namespace lamina {

namespace {

// The top exit weight after >= 1 scattering of walk i with cosine-weighted incidence: mu_i =
// sqrt(u) has density 2 mu_i on [0, 1], so its expectation is int_0^1 R_diffuse(mu) 2 mu dmu,
// the white-sky albedo. The walk's weight is per unit incident power and excludes the top's
// specular part.
Spectrum diffuse_albedo_sample(const LayerStack& stack, std::uint64_t seed, int i, const WalkSettings& settings) {
  Rng rng(seed, static_cast<std::uint64_t>(i), 0x1a3b);
  const double mu = std::sqrt(std::max(rng.uniform(), 1e-300));
  const double phi = 2.0 * kPi * rng.uniform();
  const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
  const WalkResult r = random_walk(stack, {s * std::cos(phi), s * std::sin(phi), mu}, rng, {}, settings);
  return r.side == WalkResult::Side::Top && r.scatter_count > 0 ? r.weight : Spectrum(0.0);
}

struct MeanAccumulator {
  Spectrum sum{0.0}, sum2{0.0};
  void add(const Spectrum& x) {
    sum += x;
    sum2 += x * x;
  }
  Spectrum mean(int n) const { return sum / std::max(1, n); }
  Spectrum standard_error(int n) const {
    const double m = std::max(1, n);
    Spectrum se;
    for (int c = 0; c < kChannels; ++c) {
      const double mc = sum[c] / m;
      se[c] = std::sqrt(std::max(0.0, sum2[c] / m - mc * mc) / std::max(1.0, m - 1.0));
    }
    return se;
  }
};

}  // namespace

Spectrum diffuse_bihemispherical_albedo(const LayerStack& stack, int walks, std::uint64_t seed,
                                        Spectrum* standard_error, const WalkSettings& settings) {
  MeanAccumulator acc;
  for (int i = 0; i < walks; ++i) acc.add(diffuse_albedo_sample(stack, seed, i, settings));
  if (standard_error) *standard_error = acc.standard_error(walks);
  return acc.mean(walks);
}

Spectrum diffuse_albedo_bias(const LayerStack& stack, const WalkSettings& approximate, int walks, std::uint64_t seed,
                             Spectrum* standard_error, Spectrum* exact) {
  MeanAccumulator diff, base;
  for (int i = 0; i < walks; ++i) {
    const Spectrum e = diffuse_albedo_sample(stack, seed, i, {});
    base.add(e);
    diff.add(diffuse_albedo_sample(stack, seed, i, approximate) - e);
  }
  if (standard_error) *standard_error = diff.standard_error(walks);
  if (exact) *exact = base.mean(walks);
  return diff.mean(walks);
}

}  // namespace lamina
