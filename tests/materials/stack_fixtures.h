// Layer stacks built in code for the materials tests.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "materials/stack/stack.h"

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

// Two layers over a Lambert substrate: thick, high albedo, dominated by multiple scattering
// (non-transmitting, skin-like; values illustrative, not the skin preset).
inline LayerStack skin_like_stack(std::string name = "skin-like") {
  LayerStack s;
  s.name = std::move(name);
  s.above_ior = 1.0;
  s.layers.push_back(make_layer("epi", 1.4, 0.1, Spectrum(0.5, 1.5, 3.0), Spectrum(20.0), Spectrum(0.8)));
  s.layers.push_back(make_layer("derm", 1.38, 1.0, Spectrum(0.2, 0.6, 1.0), Spectrum(15.0, 12.0, 10.0), Spectrum(0.0)));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.6, 0.4, 0.3);
  return s;
}

}  // namespace lamina::test
