#include "materials/tables/albedo.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/analytic/first_order.h"
#include "materials/walk/random_walk.h"
#include "materials/base/sampling.h"
#include "materials/analytic/zeroth_order.h"

namespace lamina {

namespace {

// The top exit weight after >= 1 scattering of walk i with cosine-weighted incidence: mu_i =
// sqrt(u) has density 2 mu_i on [0, 1], so its expectation is int_0^1 R_diffuse(mu) 2 mu dmu,
// the white-sky albedo. The walk's weight is per unit incident power and excludes the top's
// specular part. Under a diffuse top every exit the walk returns crossed it, spread: unscattered
// or not, it counts (the delta lobe, the top's mirror, is the caller's; zeroth_order_above_rough).
Spectrum diffuse_albedo_sample(const LayerStack& stack, std::uint64_t seed, int i, const WalkOptions& settings) {
  Rng rng(seed, static_cast<std::uint64_t>(i), 0x1a3b);
  const double mu = std::sqrt(std::max(rng.uniform(), 1e-300));
  const double phi = 2.0 * kPi * rng.uniform();
  const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
  const WalkResult r = random_walk(stack, {s * std::cos(phi), s * std::sin(phi), mu}, rng, {}, settings);
  const bool spread = r.scatter_count > 0 || stack.diffuse_interface(0);
  return r.side == WalkResult::Side::Top && spread ? r.weight : Spectrum(0.0);
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
                                        Spectrum* standard_error, const WalkOptions& settings) {
  MeanAccumulator acc;
  for (int i = 0; i < walks; ++i) acc.add(diffuse_albedo_sample(stack, seed, i, settings));
  if (standard_error) *standard_error = acc.standard_error(walks);
  return acc.mean(walks);
}

Spectrum diffuse_albedo_bias(const LayerStack& stack, const WalkOptions& approximate, int walks, std::uint64_t seed,
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

Spectrum diffuse_bihemispherical_albedo_adding_doubling(const LayerStack& stack, const AddingDoublingSettings& settings) {
  // R_h: one adding-doubling solution (its diffuse-incidence totals do not depend on cos_theta_i).
  const AddingDoublingTotals totals = adding_doubling_totals(stack, 1.0, settings);
  const Spectrum r_h = totals.R_hemispherical;
  // A rough top: its own (glossy) reflection is the unscattered part, from the same solution;
  // with energy-conserving rough interfaces, all the unscattered light (the walk's estimate
  // leaves out exactly that: its exits of no scattering).
  if (stack.rough_top() || stack.energy_conserving_rough()) {
    Spectrum a = r_h - totals.R_hemispherical_glossy;
    for (int c = 0; c < kChannels; ++c) a[c] = std::max(a[c], 0.0);
    return a;
  }
  // R_hs = 2 int_0^1 R_specular(mu) mu dmu, the delta lobe (zeroth_order_above_rough: under a
  // diffuse interface the unscattered light comes back spread, and belongs to the albedo; the
  // same as zeroth_order for other stacks). R_specular has a kink where an interface below starts
  // to reflect totally: at Snell's invariant n_above sin(theta) = n_k of a medium k with
  // n_k < n_above, i.e. mu = sqrt(1 - (n_k / n_above)^2). Gauss-Legendre on each segment.
  std::vector<double> cuts = {0.0, 1.0};
  auto cut_at = [&](double n) {
    if (n < stack.above_ior) cuts.push_back(std::sqrt(1.0 - (n / stack.above_ior) * (n / stack.above_ior)));
  };
  for (const Layer& l : stack.layers) cut_at(l.ior);
  if (stack.below.kind == Below::Kind::Dielectric) cut_at(stack.below.ior);
  std::sort(cuts.begin(), cuts.end());
  constexpr int kPoints = 48;
  double mu[kPoints], w[kPoints];
  Spectrum r_hs(0.0);
  for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
    if (!(cuts[k + 1] > cuts[k])) continue;
    gauss_legendre(kPoints, cuts[k], cuts[k + 1], mu, w);
    for (int i = 0; i < kPoints; ++i) r_hs += zeroth_order_above_rough(stack, mu[i]).R_specular * (2.0 * mu[i] * w[i]);
  }
  Spectrum a = r_h - r_hs;
  for (int c = 0; c < kChannels; ++c) a[c] = std::max(a[c], 0.0);
  return a;
}

}  // namespace lamina
