// The walk's exits straight through a rough top against the connection through their own inside
// direction: the check that the rough-top tests (single-scattering and energy-conserving) share.
#pragma once

#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>
#include <glm/vec3.hpp>

#include "materials/walk/random_walk.h"

namespace lamina::test {

// Runs `walks` walks of a grey stack from wi (Rng(seed, i), no roulette, exit densities on), and
// for every one that leaves straight from its last event through the top checks
// W_exit exit_pdf / |w.z| = the last event's connection weight through the walk's own inside
// direction (prepare_exit_through), to 1e-9 relative: the exit's density, Fresnel terms, n^2
// factors and attenuations must be the connection's. Returns how many it checked; the test
// fails (without stopping the caller) at the first mismatch, which ends the check.
inline int check_straight_top_exits(const LayerStack& stack, const glm::dvec3& wi, int walks, std::uint64_t seed) {
  WalkOptions no_roulette;
  no_roulette.roulette_threshold = 0.0;
  no_roulette.compute_exit_pdf = true;
  int checked = 0;
  for (int i = 0; i < walks; ++i) {
    Rng rng(seed, static_cast<std::uint64_t>(i));
    ScatterEvent last;
    const WalkResult r = random_walk(stack, wi, rng, [&](const ScatterEvent& e) { last = e; }, no_roulette);
    if (!r.straight_from_last_event || r.side != WalkResult::Side::Top) continue;
    EXPECT_FALSE(r.crossed_rough) << "walk " << i;
    ExitDirection exit;
    prepare_exit_through(stack, r.direction, r.top_inside, &exit);
    const double lhs = r.weight[0] * r.exit_pdf / r.direction.z;
    const double rhs = (last.throughput * connect_direct(stack, last, exit).weight)[0];
    if (!(std::abs(lhs - rhs) <= 1e-9 * (1.0 + rhs))) {
      ADD_FAILURE() << "walk " << i << ": W_exit pdf / |w.z| = " << lhs << ", connection " << rhs;
      return checked;
    }
    ++checked;
  }
  return checked;
}

}  // namespace lamina::test
