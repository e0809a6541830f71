// What a walk specialised to MCML's slab a could reach (the target was `lamina brdf` at 1.5x
// MCML's photons per CPU-second; the general walk is at about 0.95x). Not a product path and not run by
// the test suite: a bound, to decide whether a dedicated or restructured kernel is worth having.
//
// The slab is van de Hulst's (bench/mcml_compare.sh slab a): n 1 above, inside and below,
// sigma_a 1, sigma_s 9 /mm, g 0.75, 0.2 mm, normal incidence. The walk is the general walk's
// (materials/walk/walk_kernel.h) reduced to that case, with the same random numbers in the same
// order (the hero's uniform, the ziggurat's flights, two uniforms per Henyey-Greenstein
// direction, a uniform at each exit for its Fresnel test, WalkOptions' roulette below 1 % with
// survival 0.1; the sqrt schedule after 1,000 interactions, which no photon of this slab
// reaches, is left out) and the same tally as `lamina brdf` (totals with their squares, ends, 18
// bins of cos theta by 36 of azimuth with their single-scattering parts), so its R_d and T_d
// equal those of
//   lamina brdf out/mcml_compare/a/stack.json --theta-i 0 --samples N
// to every printed digit (its 'absorbed' takes the unscattered exits from the photons, where
// lamina brdf uses their closed form: equal within the standard error). LANES photons are kept
// in flight at once, each advanced by one flight in turn (refilled as they finish), so that
// their independent dependency chains overlap: the walk is latency-bound once its bookkeeping
// is gone.
//
//   lean_slab_walk PHOTONS [LANES]      (LANES 1, 2 or 4; default 1)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "materials/brdf/brdf_table.h"
#include "materials/phase/henyey_greenstein.h"
#include "materials/base/sampling.h"

namespace {
using namespace lamina;

constexpr double kSigmaA = 1.0, kSigmaS = 9.0, kG = 0.75, kThickness = 0.2;
constexpr double kSigmaT = kSigmaA + kSigmaS, kAlbedo = kSigmaS / kSigmaT;
constexpr double kRouletteThreshold = 0.01, kRouletteSurvival = 0.1;
constexpr int kBinsTheta = 18, kBinsPhi = 36;  // lamina brdf's defaults

struct Photon {
  Rng rng{0, 0};
  glm::dvec3 d{0.0, 0.0, -1.0};
  double z = 0.0, weight = 1.0;
  int scatter_count = 0;
  bool live = false;
};

struct Tally {
  double sum[5] = {}, sum2[5] = {};  // R_d, T_d, absorbed, unscattered top, unscattered bottom
  double ends[3] = {};               // absorbed or rouletted, top, bottom
  std::vector<double> bins = std::vector<double>(2 * kBinsTheta * kBinsPhi * 4, 0.0);
  double bin_scale[kBinsTheta];
  Tally() {
    for (int k = 0; k < kBinsTheta; ++k) {
      const double lo = double(k) / kBinsTheta, hi = double(k + 1) / kBinsTheta;
      bin_scale[k] = 1.0 / (0.5 * (hi - lo) * (hi + lo) * 2.0 * kPi / kBinsPhi);
    }
  }
  void add(const Photon& p, int side) {  // side 0: absorbed, 1: top, 2: bottom
    const bool unscattered = p.scatter_count == 0;
    const double w = p.weight;
    const double r_d = side == 1 && !unscattered ? w : 0.0, t_d = side == 2 && !unscattered ? w : 0.0;
    const double r_s = side == 1 && unscattered ? w : 0.0, t_b = side == 2 && unscattered ? w : 0.0;
    const double x[5] = {r_d, t_d, 1.0 - r_d - t_d - r_s - t_b, r_s, t_b};
    for (int s = 0; s < 5; ++s) {
      sum[s] += x[s];
      sum2[s] += x[s] * x[s];
    }
    ends[side] += 1.0;
    if (unscattered || side == 0) return;
    const int k = std::min(kBinsTheta - 1, static_cast<int>(std::abs(p.d.z) * kBinsTheta));
    const int bin = ((side - 1) * kBinsTheta + k) * kBinsPhi + azimuth_bin(p.d.x, p.d.y, 0.0, kBinsPhi);
    const double v = w * bin_scale[k];
    double* slot = &bins[bin * 4];
    slot[0] += v;
    slot[1] += v * v;
    if (p.scatter_count == 1) {
      slot[2] += v;
      slot[3] += v * v;
    }
  }
};

// One flight and what ends it: returns -1 while the photon lives, else its side for the tally.
inline int step(Photon& p) {
  const double tau = sample_exponential(p.rng);
  const double room = p.d.z < 0.0 ? kThickness - p.z : p.z;
  if (tau * std::abs(p.d.z) < room * kSigmaT) {
    p.z -= tau / kSigmaT * p.d.z;
    p.weight *= kAlbedo;
    ++p.scatter_count;
    const double u1 = p.rng.uniform(), u2 = p.rng.uniform();
    p.d = sample_henyey_greenstein(p.d, kG, u1, u2);
    if (p.weight < kRouletteThreshold) {
      if (p.rng.uniform() >= kRouletteSurvival) return 0;
      p.weight /= kRouletteSurvival;
    }
    return -1;
  }
  (void)p.rng.uniform();  // the exit's Fresnel test, R = 0 with matched indices
  return p.d.z > 0.0 ? 1 : 2;
}

template <int kLanes>
Tally run(std::uint64_t photons) {
  Tally tally;
  std::uint64_t next = 0;
  auto launch = [&](Photon& p) {
    p.live = next < photons;
    if (!p.live) return;
    p.rng = Rng(1, next++);  // lamina brdf's stream for photon i (its default seed, 1)
    p.d = {0.0, 0.0, -1.0};
    p.z = 0.0;
    p.weight = 1.0;  // matched index: no entry reflection
    p.scatter_count = 0;
    (void)p.rng.uniform();  // the hero's uniform
  };
  Photon lanes[kLanes];
  int live = 0;
  for (Photon& p : lanes) {
    launch(p);
    live += p.live;
  }
  while (live > 0) {
    for (Photon& p : lanes) {
      if (!p.live) continue;
      const int side = step(p);
      if (side < 0) continue;
      tally.add(p, side);
      launch(p);
      if (!p.live) --live;
    }
  }
  return tally;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: lean_slab_walk PHOTONS [LANES: 1, 2 or 4]\n");
    return 2;
  }
  const std::uint64_t photons = std::strtoull(argv[1], nullptr, 10);
  const int lanes = argc > 2 ? std::atoi(argv[2]) : 1;
  if (photons < 2 || (lanes != 1 && lanes != 2 && lanes != 4)) {
    std::fprintf(stderr, "lean_slab_walk: PHOTONS >= 2 and LANES 1, 2 or 4\n");
    return 2;
  }
  const Tally t = lanes == 1 ? run<1>(photons) : lanes == 2 ? run<2>(photons) : run<4>(photons);
  const double n = static_cast<double>(photons);
  auto report = [&](const char* name, int s) {
    const double mean = t.sum[s] / n;
    std::printf("%s %.6g +- %.6g\n", name, mean, std::sqrt(std::max(0.0, t.sum2[s] / n - mean * mean) / (n - 1.0)));
  };
  report("R_diffuse", 0);
  report("T_diffuse", 1);
  report("absorbed", 2);
  return 0;
}
