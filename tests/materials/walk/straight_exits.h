// The walk's exits straight through a rough top against the connection through their own inside
// direction: the check that the rough-top tests (single-scattering and energy-conserving) share.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>

#include <gtest/gtest.h>
#include <glm/vec3.hpp>

#include "materials/base/sampling.h"
#include "materials/walk/random_walk.h"
#include "tests/support/statistics.h"

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

// The light that leaves straight from the walk's last event through one side (side +1 the top,
// -1 the bottom), two independent ways: the connections towards a cosine-sampled direction w
// (prepare_exit with an rng, which crosses rough and diffuse interfaces by sampling), weighted
// |w.z| / p(w), against the exits' own weights; 100 000 walks from wi, Rng(seed, k). Expects the
// two means within 4 standard errors and the exits' mean 30 standard errors above 0;
// `on_straight_exit` sees every such exit's result.
inline void expect_connections_match_straight_exits(
    const LayerStack& s, const glm::dvec3& wi, double side, std::uint64_t seed,
    const std::function<void(const WalkResult&)>& on_straight_exit = [](const WalkResult&) {}) {
  RunningStats exits, connections;
  ExitDirection exit;
  for (int k = 0; k < 100000; ++k) {
    Rng rng(seed, k);
    glm::dvec3 w = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    const double p = w.z * kInvPi;
    w.z *= side;
    prepare_exit(s, w, &exit, 0.0, {0.5, 0.5}, &rng);
    double sum = 0.0;
    const WalkResult r = random_walk(s, wi, rng, [&](const ScatterEvent& e) { sum += (e.throughput * connect_direct(s, e, exit).weight)[0]; });
    connections.add(sum * std::abs(w.z) / p);
    const bool straight_out = r.straight_from_last_event && r.direction.z * side > 0.0 && r.side != WalkResult::Side::None;
    exits.add(straight_out ? r.weight[0] : 0.0);
    if (straight_out) on_straight_exit(r);
  }
  const double se = std::hypot(exits.standard_error(), connections.standard_error());
  EXPECT_NEAR(exits.mean(), connections.mean(), 4.0 * se) << "side " << side;
  EXPECT_GT(exits.mean(), 30.0 * se) << "side " << side;
}

}  // namespace lamina::test
