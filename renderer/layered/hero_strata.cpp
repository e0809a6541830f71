#include "renderer/layered/hero_strata.h"

#include <algorithm>

#include "materials/base/sampling.h"
#include "materials/base/spectrum.h"

namespace lamina {

// Stratified hero channel (one-sample MIS made multi-sample over a pixel's samples).
//
// The walk's weights (random_walk.cpp, "Spectral MIS") are the one-sample balance heuristic: a
// hero h drawn with probability 1/3, weight W_c = f_c / ((1/3) sum_k p_k). E[W_c] = integral f_c
// needs only that h be uniform MARGINALLY and independent of the rest of the walk's randomness;
// nothing requires the heroes of different walks to be independent. Here the k-th walk of
// sample i of a pixel uses h = (i + o_k) mod 3 with o_k uniform on {0, 1, 2} from a stream of its
// own, keyed by (seed, pixel, k) and never by thread:
//  * marginally, P(h = c) = P(o_k = (c - i) mod 3) = 1/3 for every i, and o_k is independent of
//    sample i's stream (and so of the path before the walk, which decides whether there is a k-th
//    walk at all): each sample is the unbiased one-sample estimator, so the pixel mean is
//    unbiased for ANY spp, multiple of 3 or not;
//  * over samples 3m, 3m+1, 3m+2 every channel is the hero of the k-th walk exactly once. For
//    the first walk (same pixel, nearly the same entry point and direction) three such samples
//    are the multi-sample MIS estimator with one sample per technique and balance-heuristic
//    weights (Veach 1997, section 9.2: sum_c w_c(X_c) f(X_c) / p_c(X_c) with
//    w_c = p_c / sum_k p_k, i.e. sum_c f(X_c) / sum_k p_k(X_c), which is the mean of the three
//    samples' one-sample weights 3 f / sum_k p_k). The number of walks per hero in a pixel is
//    no longer multinomial, which removes the chroma noise that came from one channel being the
//    hero more often than the others. Later walks (k > 0) start from diverged paths and gain
//    less (their offsets are still stratified per walk index).
// Light samples at events need no change: connection_weight and the event's throughput are
// conditional on the walk's hero, and exit_pdf_for_mis is the mean over the three heroes, which
// does not depend on how the hero was chosen (materials/walk/walk_estimator.h, exit_pdf_for_mis).
int HeroStrata::hero(int walk_index) const {
  Rng offset_rng(seed, pixel, kHeroStream + static_cast<std::uint64_t>(walk_index));
  const int offset = std::min(kChannels - 1, static_cast<int>(offset_rng.uniform() * kChannels));
  return static_cast<int>((sample + static_cast<std::uint64_t>(offset)) % kChannels);
}

}  // namespace lamina
