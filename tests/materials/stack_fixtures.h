// Layer stacks built in code for the materials tests.
#pragma once

#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "materials/stack.h"

namespace lamina::test {

// The stack of `layers` between media of index `above` and `below`; the test fails (without
// stopping) if the stack is not valid.
inline LayerStack stack_of(std::vector<Layer> layers, double above = 1.0, double below = 1.0) {
  LayerStack s;
  s.above_ior = above;
  s.layers = std::move(layers);
  s.below.ior = below;
  EXPECT_EQ(validate_stack(s), "");
  return s;
}

// One slab (index n, thickness, sigma_a, sigma_s, HG g) between media of index above and below.
// Not validated: tests use it for the extremes too.
inline LayerStack one_layer(double n, double thickness, Spectrum sa, Spectrum ss, Spectrum g, double above = 1.0,
                            double below = 1.0) {
  LayerStack s;
  s.above_ior = above;
  s.layers.push_back(make_layer("slab", n, thickness, sa, ss, g));
  s.below.ior = below;
  return s;
}

}  // namespace lamina::test
