// The stratified hero channel of the random walks of a pixel (hero_strata.cpp has the derivation).
#pragma once

#include <cstdint>

namespace lamina {

// Where a camera sample sits among the samples of its pixel, for the stratified hero channel:
// the k-th random walk of sample `sample` in pixel `pixel` uses hero (sample + o_k) mod 3, where
// the offset o_k is uniform on {0, 1, 2}, drawn from Rng(seed, pixel, kHeroStream + k): the same
// for every sample of the pixel, independent of each sample's own stream.
struct HeroStrata {
  static constexpr std::uint64_t kHeroStream = 1ull << 62;  // far above any sample index
  std::uint64_t seed = 0;
  std::uint64_t pixel = 0;
  std::uint64_t sample = 0;
  int hero(int walk_index) const;
};

}  // namespace lamina
