// A stochastic surface under a uniform sky, shared by the surface tests.
#pragma once

#include <cmath>
#include <cstdint>

#include <glm/vec3.hpp>

#include "materials/base/sampling.h"
#include "renderer/surfaces/surface.h"
#include "tests/support/statistics.h"

namespace lamina::test {

// The surface under a uniform sky of radiance 1 sampled by the cosine: one light sample per call,
// MIS against the surface's continuation (weight 1 for a delta continuation). Its mean is the
// surface's albedo at wo (side -1: the sky below, the surface's transmittance).
inline void sky_furnace(const Surface& surface, const glm::dvec3& wo, std::uint64_t seed, int calls, RunningStats* est,
                        double side = 1.0) {
  for (int k = 0; k < calls; ++k) {
    Rng rng(seed, k);
    LightDirection light;
    light.wi = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    light.pdf = light.wi.z * kInvPi;
    light.wi.z *= side;
    SurfaceScatter next;
    Spectrum x(0.0);
    if (surface.scatter(wo, rng, &light, 1, nullptr, &next) && next.wi.z * side > 0.0)
      x = next.weight * (next.delta ? 1.0 : power_heuristic(next.pdf, std::abs(next.wi.z) * kInvPi));
    x += light.f_cos / light.pdf;
    for (int c = 0; c < 3; ++c) est[c].add(x[c]);
  }
}

}  // namespace lamina::test
